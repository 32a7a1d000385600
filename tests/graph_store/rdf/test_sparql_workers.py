"""A view runs queries on a small pool of worker processes: a long query does not hold up
the next one; with every worker busy, a query waits for one within its own timeout."""

from __future__ import annotations

import threading
import time

import pytest

from graph_store.errors import SparqlArgumentError, SparqlTimeoutError
from graph_store.rdf import RdfView
from graph_store.rdf._sparql_worker import can_isolate
from tests.strategies import random_scene

pytestmark = pytest.mark.skipif(not can_isolate(), reason="worker processes need fork (Linux)")

#: Counting a three-way product of every triple: runs far past any timeout here, in
#: constant memory.
ENDLESS = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?p ?x . ?b ?q ?y . ?c ?r ?z }"


def _endless(view: RdfView, outcome: list[BaseException | None], seconds: float) -> None:
    try:
        view.query(ENDLESS, timeout_s=seconds)
        outcome.append(None)
    except BaseException as exc:
        outcome.append(exc)


def test_a_long_query_does_not_hold_up_the_next_and_a_full_pool_times_out() -> None:
    view = RdfView.from_graphs(random_scene("s", 60, 200, seed=3), backend="oxigraph")
    assert view.workers == 2
    outcomes: list[BaseException | None] = []
    first = threading.Thread(target=_endless, args=(view, outcomes, 15.0))
    first.start()
    try:
        # answered by the second worker while the first is busy
        assert view.query("ASK { ?s ?p ?o }", timeout_s=60).boolean is True
        assert first.is_alive()
        second = threading.Thread(target=_endless, args=(view, outcomes, 15.0))
        second.start()
        # a started thread may not have taken its worker yet: wait until both hold one
        deadline = time.monotonic() + 60
        while view.busy < 2:
            assert time.monotonic() < deadline, "the two long queries never held both workers"
            time.sleep(0.01)
        # both busy: a third query waits its own time, then says why
        with pytest.raises(SparqlTimeoutError, match="all 2 workers of this view stayed busy"):
            view.query("ASK { ?s ?p ?o }", timeout_s=1.0)
    finally:
        # each long query is stopped at its own timeout, its worker killed
        first.join(timeout=120)
        second.join(timeout=120)
        view.close()
    assert len(outcomes) == 2 and all(isinstance(o, SparqlTimeoutError) for o in outcomes)


def test_workers_must_be_a_positive_count() -> None:
    from graph_store.rdf._sparql_backends import OxigraphBackend

    with pytest.raises(SparqlArgumentError, match="workers must be an integer >= 1, got 0"):
        RdfView(OxigraphBackend(()), (), workers=0)
