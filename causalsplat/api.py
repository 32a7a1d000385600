"""The public Python API (DESIGN §10): open a store, add scenes, query them.

.. code-block:: python

    from causalsplat import open_store

    store = open_store("sqlite:///scenes.db")        # or postgresql+psycopg://...
    scene = store.ingest_objects("objects.json")     # a stored scene handle
    scene = store.scene("scene0000_00")
    rows = scene.sparql("SELECT ?a ?b WHERE { ?a csg:above ?b }")

A :class:`Scene` is a handle on one stored scene. It reads the graph from the store the
first time it is needed and keeps it (and its RDF view) for later calls; call
:meth:`Scene.reload` after the scene was replaced in the store. Nothing here imports torch.
"""

from __future__ import annotations

import errno
import os
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from graph_store import (
    Entity,
    GraphStore,
    SceneExistsError,
    SceneGraph,
    SceneNotFound,
    SceneSummary,
)
from graph_store import open_store as _open_graph_store
from graph_store.repository import IfExists

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from causalsplat.build import BuildConfig, BuildResult
    from causalsplat.build.batch import BatchIfExists, BatchReport
    from causalsplat.eval.reasoning import EvalReport
    from causalsplat.export import PlyExport
    from causalsplat.reason import Answer, Reasoner, SceneContext
    from graph_store.rdf import RdfView, SparqlResult
    from queries import Executor, GraphQuery, MultiSceneResult, QueryResult

DEFAULT_URL = "sqlite:///causalsplat.db"
RdfFormat = Literal["turtle", "ntriples", "jsonld"]
SparqlBackend = Literal["auto", "oxigraph", "rdflib"]


def open_store(url: str | os.PathLike[str] | None = None, *, create: bool = True) -> Store:
    """Open the store at ``url``: a database URL or a SQLite file's path (default
    ``$CAUSALSPLAT_DB`` or ``sqlite:///causalsplat.db``).

    With ``create`` true, a SQLite file that does not exist is created by the first write
    (until then the store reads as empty, and a mistyped path creates nothing), and an
    empty PostgreSQL database is initialised; with ``create`` false, a missing file raises
    ``StoreNotFoundError``. Raises ``StoreConnectionError`` or ``SchemaVersionError`` (see
    ``graph_store``).
    """
    if url is None:
        url = os.environ.get("CAUSALSPLAT_DB") or DEFAULT_URL
    return Store(_open_graph_store(url, create=create))


class Store:
    """A database of scene graphs, with the operations users run on it."""

    def __init__(self, graph_store: GraphStore) -> None:
        self.graph_store = graph_store
        self._views: dict[tuple[Any, ...], RdfView] = {}
        self._views_lock = threading.Lock()

    def __repr__(self) -> str:
        return f"Store({self.graph_store.url!r})"

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the database connections and end the SPARQL views' worker processes."""
        with self._views_lock:
            for view in self._views.values():
                view.close()
            self._views.clear()
        self.graph_store.close()

    def backup(self, path: str | Path) -> Path:
        """Copy this SQLite store into the new file ``path`` while it may be in use
        (SQLite's online backup); see :meth:`graph_store.GraphStore.backup`."""
        return self.graph_store.backup(path)

    # -- scenes ------------------------------------------------------------------------

    def scenes(self) -> list[SceneSummary]:
        """Summaries of all stored scenes, ordered by id."""
        return self.graph_store.list_scenes()

    def scene_ids(self, scenes: str | Sequence[str] | None = None) -> tuple[str, ...]:
        """The stored scene ids ``scenes`` selects, sorted: all (``None``), those matching
        a glob (``"scene00*"``) or the ids listed. Raises ``SceneNotFound`` when a glob
        matches nothing or a listed id is not stored."""
        from queries import select_scene_ids

        return select_scene_ids(self.graph_store, scenes)

    def scene(self, scene_id: str) -> Scene:
        """A handle on a stored scene; raises ``SceneNotFound``."""
        if not self.graph_store.has_scene(scene_id):
            raise SceneNotFound(f"no scene {scene_id!r} in the store at {self.graph_store.where}")
        return Scene(self, scene_id)

    def save_scene(
        self,
        graph: SceneGraph,
        *,
        if_exists: IfExists = "fail",
        gaussian_labels: npt.ArrayLike | None = None,
    ) -> Scene:
        """Store a scene graph atomically and return its handle."""
        self.graph_store.save_scene(graph, if_exists=if_exists, gaussian_labels=gaussian_labels)
        return Scene(self, graph.scene_id, graph=graph)

    def delete_scene(self, scene_id: str) -> None:
        self.graph_store.delete_scene(scene_id)

    def ingest_objects(
        self,
        path: str | Path,
        *,
        scene_id: str | None = None,
        if_exists: IfExists = "fail",
    ) -> Scene:
        """Store the scene graph of an objects file (docs/formats.md) and return its handle."""
        from causalsplat.objects import objects_graph

        return self.save_scene(objects_graph(path, scene_id=scene_id), if_exists=if_exists)

    def build(
        self,
        path: str | Path,
        *,
        scene_id: str | None = None,
        config: BuildConfig | str | Path | None = None,
        if_exists: IfExists = "fail",
        cache_dir: str | Path | bool | None = True,
        progress: bool = False,
    ) -> Scene:
        """Build a scene folder (docs/formats.md) into a scene graph and store it with its
        per-Gaussian labels; returns the scene handle.

        ``config`` is a :class:`~causalsplat.build.config.BuildConfig` or the path of its
        JSON file. Stages are cached by content under ``cache_dir`` (``True``: the default
        directory, ``False``: none). The build report (stage timings, peak memory,
        instance quality) is ``scene.build_report``; :func:`causalsplat.build.build_scene`
        returns it without storing anything.
        """
        from causalsplat.build import BuildConfig, build_scene

        if isinstance(config, str | Path):
            config = BuildConfig.from_file(config)
        if if_exists == "fail":  # refuse before the build, not after it
            from causalsplat.build.pipeline import scene_id_of

            sid = scene_id_of(path, scene_id)
            if self.graph_store.has_scene(sid):
                raise SceneExistsError(
                    f"scene {sid!r} is already stored; pass if_exists='replace'"
                    " (CLI: --if-exists replace) to overwrite it"
                )
        result = build_scene(
            path, scene_id=scene_id, config=config, cache_dir=cache_dir, progress=progress
        )
        scene = self.save_scene(
            result.graph, if_exists=if_exists, gaussian_labels=result.gaussian_labels
        )
        scene.build_report = result
        return scene

    def build_many(
        self,
        folders: Sequence[str | Path],
        *,
        workers: int | None = None,
        ray_address: str | None = None,
        config: BuildConfig | str | Path | None = None,
        if_exists: BatchIfExists = "skip",
        retries: int = 1,
        cache_dir: str | Path | bool | None = True,
        report_path: str | Path | None = None,
        progress: Callable[[str], None] | None = None,
    ) -> BatchReport:
        """Build many scene folders into this store, resumably, in worker processes or on
        a Ray cluster (``ray_address``); see :func:`causalsplat.build.batch.build_many`.
        Scenes already stored with the same inputs are skipped; a failed scene is in the
        report (``report.failed``), never raised."""
        from causalsplat.build import BuildConfig
        from causalsplat.build.batch import build_many

        if isinstance(config, str | Path):
            config = BuildConfig.from_file(config)
        url = self.graph_store.engine.url.render_as_string(hide_password=False)
        return build_many(
            folders, url, workers=workers, ray_address=ray_address, config=config,
            if_exists=if_exists, retries=retries, cache_dir=cache_dir,
            report_path=report_path, progress=progress,
        )  # fmt: skip

    # -- RDF ---------------------------------------------------------------------------

    def export_rdf(
        self,
        path: str | Path | None,
        *,
        scene_ids: Sequence[str] | None = None,
        format: RdfFormat = "turtle",
        evidence: bool = True,
    ) -> str | None:
        """Export scenes (all when ``scene_ids`` is None) as RDF.

        Writes ``path`` atomically (a temporary file renamed into place) and returns
        ``None``; with ``path=None`` returns the document as a string.
        """
        from graph_store.rdf import serialize_scenes

        graphs = self._graphs(scene_ids)
        text = serialize_scenes(graphs, format, evidence=evidence)
        if path is None:
            return text
        _write_atomic(Path(path), text)
        return None

    def sparql(
        self,
        query: str,
        *,
        scene_ids: Sequence[str] | None = None,
        bindings: Mapping[str, Any] | None = None,
        limit: int = 10_000,
        timeout_s: float = 30.0,
        backend: SparqlBackend = "auto",
        evidence: bool = True,
        default_graphs: Sequence[str] | None = None,
        named_graphs: Sequence[str] | None = None,
    ) -> SparqlResult:
        """Read-only SPARQL over the RDF view of some scenes (all when ``scene_ids`` is None).

        The view holds the triples :meth:`export_rdf` writes, relation evidence included
        (``csg:RelationAssertion`` nodes and their ``csg:hasEvidence`` values); it is built
        once and reused while the scenes it holds are unchanged in the store.
        ``evidence=False`` leaves the assertion nodes out: a lighter view (about a sixth of
        the triples of scene0000_00) on which evidence queries answer nothing. Each scene is
        a named graph (its scene IRI) and the default graph their union;
        ``default_graphs`` / ``named_graphs`` replace the query's dataset
        (:meth:`graph_store.rdf.RdfView.query`).
        """
        from graph_store.rdf import RdfView

        with_evidence = evidence
        stamps = {s.scene_id: s.created_at for s in self.scenes()}
        ids = tuple(sorted(stamps)) if scene_ids is None else tuple(sorted(set(scene_ids)))
        for sid in ids:
            if sid not in stamps:
                raise SceneNotFound(f"no scene {sid!r} in the store at {self.graph_store.url}")
        key = (ids, tuple(stamps[sid] for sid in ids), backend, with_evidence)
        with self._views_lock:  # queries on several threads share one view
            view = self._views.get(key)
            if view is None:
                graphs = [self.graph_store.load_scene(sid) for sid in ids]
                for old in self._views.values():
                    old.close()
                self._views.clear()  # keep one view: they can be large
                view = self._views[key] = RdfView.from_graphs(
                    graphs, backend=backend, evidence=with_evidence
                )
        return view.query(query, bindings=bindings, limit=limit, timeout_s=timeout_s,
                          default_graphs=default_graphs, named_graphs=named_graphs)  # fmt: skip

    # -- questions across scenes -------------------------------------------------------

    def query_all(
        self,
        program: GraphQuery | str | bytes | dict[str, Any],
        *,
        scenes: str | Sequence[str] | None = None,
        executor: str = "sql",
    ) -> MultiSceneResult:
        """Run a structured program on every selected scene (all, a glob or a list).

        Each scene's result is the one :meth:`Scene.run` gives; ``sql`` answers all scenes
        with one statement, ``sparql`` with one query per step on one dataset holding them
        all, ``networkx`` scene after scene. The result maps scene ids to results in id order;
        ``.answered()`` keeps the scenes with a non-empty answer.
        """
        from queries import run_program_all

        return run_program_all(self.graph_store, program, scenes=scenes, executor=executor)

    def ask_all(
        self,
        text: str,
        *,
        scenes: str | Sequence[str] | None = None,
        reasoner: str | Reasoner = "offline",
        **options: Any,
    ) -> dict[str, Answer]:
        """Answer one instruction on every selected scene: scene id -> :class:`Answer`,
        in id order.

        Grounding depends on each scene's categories, so each scene is answered on its
        own, by one reasoner built once (the same answers as :meth:`Scene.ask`, less the
        per-Gaussian masks, which are not read). Empty answers are kept; filter on
        ``answer.entity_ids`` / ``answer.value``.
        """
        from causalsplat.reason import SceneContext, make_reasoner

        ids = self.scene_ids(scenes)
        backend = make_reasoner(reasoner, **options)
        return {
            sid: backend.answer(text, SceneContext(self.graph_store.load_scene(sid))) for sid in ids
        }

    def _graphs(self, scene_ids: Sequence[str] | None) -> list[SceneGraph]:
        ids: Iterable[str]
        ids = scene_ids if scene_ids is not None else [s.scene_id for s in self.scenes()]
        return [self.graph_store.load_scene(sid) for sid in ids]


class Scene:
    """A handle on one stored scene."""

    def __init__(self, store: Store, scene_id: str, *, graph: SceneGraph | None = None) -> None:
        self.store = store
        self.id = scene_id
        self._graph = graph
        self._rdf: dict[str, RdfView] = {}
        self._executors: dict[str, Executor] = {}
        #: The report of the build that made this handle (``Store.build`` only).
        self.build_report: BuildResult | None = None

    def __repr__(self) -> str:
        return f"Scene({self.id!r})"

    @property
    def graph(self) -> SceneGraph:
        """The scene graph, read from the store on first use."""
        if self._graph is None:
            self._graph = self.store.graph_store.load_scene(self.id)
        return self._graph

    def reload(self) -> Scene:
        """Forget cached state so the next access reads the store again."""
        self._graph = None
        self._rdf.clear()
        self._executors.clear()
        return self

    @property
    def entities(self) -> tuple[Entity, ...]:
        return self.graph.entities

    def get_entity(self, entity_id: int) -> Entity:
        return self.graph.get_entity(entity_id)

    def find_entity(self, entity_id: int) -> Entity | None:
        return self.graph.find_entity(entity_id)

    def has_entity(self, entity_id: int) -> bool:
        return self.graph.has_entity(entity_id)

    def gaussian_labels(self) -> np.ndarray | None:
        """``(N,)`` int32 entity id per Gaussian (``-1``: none), or ``None``."""
        return self.store.graph_store.load_gaussian_labels(self.id)

    def sparql(
        self,
        query: str,
        *,
        bindings: Mapping[str, Any] | None = None,
        limit: int = 10_000,
        timeout_s: float = 30.0,
        backend: SparqlBackend = "auto",
        evidence: bool = True,
    ) -> SparqlResult:
        """Read-only SPARQL over this scene's RDF view (built once per handle).

        Standard prefixes (``csg:``, ``bot:``, ``geo:``, ``rdf:``, ``rdfs:``, ``xsd:``,
        ``owl:``) are predeclared; user values go in through ``bindings``. The view holds
        the triples :meth:`export_rdf` writes, relation evidence included (``evidence=False``:
        without the assertion nodes).
        """
        with_evidence = evidence
        key = f"{backend}:{with_evidence}"
        view = self._rdf.get(key)
        if view is None:
            from graph_store.rdf import RdfView

            view = self._rdf[key] = RdfView.from_graphs(
                [self.graph], backend=backend, evidence=with_evidence
            )
        return view.query(query, bindings=bindings, limit=limit, timeout_s=timeout_s)

    def export_rdf(
        self, path: str | Path | None, *, format: RdfFormat = "turtle", evidence: bool = True
    ) -> str | None:
        """Export this scene as RDF (see :meth:`Store.export_rdf`)."""
        return self.store.export_rdf(path, scene_ids=[self.id], format=format, evidence=evidence)

    def export_ply(
        self,
        path: str | Path,
        *,
        source: str | Path | None = None,
        embed: bool = False,
        per_entity_dir: str | Path | None = None,
    ) -> PlyExport:
        """A built scene's 3DGS PLY, unchanged, with its labels beside it (``embed=True``:
        in it, as ``causalsplat_entity``); see :func:`causalsplat.export.export_labelled_ply`.
        """
        from causalsplat.export import export_labelled_ply

        return export_labelled_ply(self.graph, self.gaussian_labels(), path, source=source,
                                   embed=embed, per_entity_dir=per_entity_dir)  # fmt: skip

    def export_masks(
        self,
        entity_ids: Iterable[int],
        out_dir: str | Path,
        *,
        source: str | Path | None = None,
        views: Sequence[str] | None = None,
        overlay: bool = False,
    ) -> list[Path]:
        """Per-view PNG masks of some entities' Gaussians (e.g. an answer's
        ``entity_ids``), optionally drawn over the views' images; see
        :func:`causalsplat.export.export_answer_masks`."""
        from causalsplat.export import export_answer_masks

        return export_answer_masks(self.graph, self.gaussian_labels(), entity_ids, out_dir,
                                   source=source, views=views, overlay=overlay)  # fmt: skip

    def export_figure(self, path: str | Path, *, width: int = 1200) -> Path:
        """A top-down PNG of the scene graph; see :func:`causalsplat.export.draw_scene_graph`."""
        from causalsplat.export import draw_scene_graph

        return draw_scene_graph(self.graph, path, width=width)

    # -- reasoning ---------------------------------------------------------------------

    def ask(self, text: str, *, reasoner: str | Reasoner = "offline", **options: Any) -> Answer:
        """Answer an instruction with a reasoner (``"offline"``, ``"vlm"`` or an instance).

        ``options`` go to the reasoner (``embeddings=False`` for WordNet word overlap only
        in the offline one, which uses sentence embeddings when the ``embed`` extra is
        installed; ``config``, ``record``, ``replay``, ``fallback`` for the VLM one). The
        answer carries the program, its result, the entity ids (``.entity_ids``,
        ``.external_ids``), the ranked candidates with their scores and evidence
        (``.candidates``), a per-Gaussian mask when the scene stores labels, and an
        explanation. A well-formed sentence is never an error: when nothing in the scene
        fits, the answer is empty and says what came closest. Raises ``InstructionError``
        only for input that is not an instruction (not a string, no words, or longer than
        2,000 characters).
        """
        return self._reasoner(reasoner, options).answer(text, self._reasoning_context())

    def run(
        self, program: GraphQuery | str | bytes | dict[str, Any], *, executor: str = "networkx"
    ) -> QueryResult:
        """Run a structured program (a ``GraphQuery``, its JSON or its dict) on this scene
        with the ``networkx`` (the reference, on networkx graphs), ``memory`` (the same on
        plain dicts), ``sql`` or ``sparql`` executor.

        The handle keeps each executor it made (the graphs, the RDF dataset, the SQL
        executor's scene ids) for the next program, until :meth:`reload`."""
        from queries import GraphQuery, make_executor

        query = GraphQuery.parse(program)
        runner = self._executors.get(executor)
        if runner is None:
            source = (
                self.graph
                if executor in ("networkx", "memory", "sparql")
                else (self.store.graph_store)
            )
            runner = make_executor(source, self.id, executor=executor)
            self._executors[executor] = runner
        return runner.run(query)

    def evaluate(
        self,
        queries_file: str | Path,
        *,
        reasoner: str | Reasoner = "offline",
        gt_labels: str | Path | np.ndarray | None = None,
        **options: Any,
    ) -> EvalReport:
        """Accuracy, 3D mIoU and F1 of a reasoner over a queries file (docs/formats.md), overall
        and per reasoning type (the numbers of ``causalsplat eval``).

        ``gt_labels`` (an ``.npy`` path or an array: the GT instance of every Gaussian)
        scores a scene built by the pipeline against its ground truth, targets being GT
        instance ids (see :mod:`causalsplat.eval.reasoning`)."""
        from causalsplat.eval.reasoning import evaluate_queries, read_queries

        backend = self._reasoner(reasoner, options)
        queries = read_queries(queries_file)
        gt = None
        if gt_labels is not None:
            import numpy as np

            gt = np.load(gt_labels) if isinstance(gt_labels, str | Path) else gt_labels
        return evaluate_queries(self._reasoning_context(), queries, backend, gt_labels=gt)

    def _reasoning_context(self) -> SceneContext:
        from causalsplat.reason import SceneContext

        ctx: SceneContext | None = getattr(self, "_reason_ctx", None)
        if ctx is None or ctx.graph is not self.graph:
            ctx = SceneContext(self.graph, labels=self.gaussian_labels)
            self._reason_ctx = ctx
        return ctx

    def _reasoner(self, reasoner: str | Reasoner, options: dict[str, Any]) -> Reasoner:
        from causalsplat.reason import make_reasoner

        if not isinstance(reasoner, str) or options:
            return make_reasoner(reasoner, **options)
        cache: dict[str, Reasoner] = self.__dict__.setdefault("_reasoners", {})
        if reasoner not in cache:
            cache[reasoner] = make_reasoner(reasoner)
        return cache[reasoner]


def _write_atomic(path: Path, text: str) -> None:
    """Write a file so that a crash leaves either the old file or the new one."""
    if path.is_dir():
        raise IsADirectoryError(errno.EISDIR, "the output is a folder, give a file path", str(path))
    from causalsplat._atomic import atomic_target

    with atomic_target(path) as tmp, tmp.open("w", encoding="utf-8", newline="\n") as handle:
        handle.write(text)
        handle.flush()
        os.fsync(handle.fileno())
