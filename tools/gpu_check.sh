#!/usr/bin/env bash
# The GPU figures of docs/scale.md and docs/ground-truth.md in one call, each step under its own
# time limit, each step's output in one file of OUT (GL strings, golden check, the ground truth's
# closed-form tests, bench dataset's rates and stages, and the same rates with NVIDIA's driver
# told to sleep rather than spin while it waits for the GPU; what a GL call group costs the CPU,
# tools/gl_overheads.py). The limits add up to 575 s, under the 600 s a device command may run;
# six files, under the eight a run brings back.
#
#   bash tools/gpu_check.sh OUT [WORKERS] [COUNT] [DEFLATES]
#   # defaults: WORKERS 4,16, COUNT 160, DEFLATES isal,stored (the images' PNG encodings)
#
# On a GPU machine prepared as ../shared/gpu/README.md says, from the project root:
#   source .gpu/setup.sh && bash tools/gpu_check.sh "$OUT"
# Here (llvmpipe) it runs as well, e.g. `bash tools/gpu_check.sh /tmp/gc 1,2 24`: the same
# steps on the CPU renderer, to check the script before spending GPU time on it.
set -u
usage="usage: tools/gpu_check.sh OUT [WORKERS] [COUNT] [DEFLATES]"
out=${1:?$usage}
workers=${2:-4,16}
count=${3:-160}
deflates=${4:-isal,stored}
# every argument checked before the first step: one line and exit 2, as the CLI does
if ! [[ $workers =~ ^[1-9][0-9]*(,[1-9][0-9]*)*$ ]]; then
  echo "Error: WORKERS must be worker counts >= 1 separated by commas (e.g. 4,16), got '$workers'; $usage" >&2
  exit 2
fi
if ! [[ $count =~ ^[1-9][0-9]*$ ]]; then
  echo "Error: COUNT must be an integer >= 1 (pairs per bench run), got '$count'; $usage" >&2
  exit 2
fi
if ! [[ $deflates =~ ^(isal|libdeflate|zlib|stored)(,(isal|libdeflate|zlib|stored))*$ ]]; then
  echo "Error: DEFLATES must be PNG deflates (isal, libdeflate, zlib, stored) separated by commas, got '$deflates'; $usage" >&2
  exit 2
fi
mkdir -p "$out" || { echo "Error: cannot make the folder OUT '$out'; give a folder you may write" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failed=()

step() {  # step NAME SECONDS COMMAND...: the command's output into OUT/NAME.txt, its status last
  local name=$1 limit=$2
  shift 2
  local start=$SECONDS
  timeout --kill-after=10 "$limit" "$@" > "$out/$name.txt" 2>&1
  local rc=$?
  echo "exit status $rc after $((SECONDS - start)) s" >> "$out/$name.txt"
  echo "$name: exit status $rc after $((SECONDS - start)) s"
  if [ "$rc" -ne 0 ]; then failed+=("$name"); fi
}

gl_strings() {  # one process per backend: PyOpenGL picks its platform once per process
  for backend in egl osmesa; do
    python3 -c "
import sys
from synth.render.renderer import Renderer
try:
    with Renderer(64, 48, backend=sys.argv[1]) as r:
        print(sys.argv[1], '|', r.gl_renderer, '|', r.gl_version)
except Exception as e:
    print(sys.argv[1], '| failed:', str(e).splitlines()[0])
" "$backend"
  done
}
export -f gl_strings
step gl 30 bash -c gl_strings
step gl_overheads 30 python3 tools/gl_overheads.py --backend egl
step golden 135 stereoforge golden check --backend egl
step ground_truth 80 python3 -m pytest -q -p no:cacheprovider tests/synth/test_ground_truth.py
step bench 180 stereoforge bench dataset --configs flying --size 960x540 --workers "$workers" \
  --count "$count" --image-deflate "$deflates" --backend egl --out "$work/bench"
# NVIDIA's GL driver waits for the GPU by calling sched_yield in a loop (a busy core, counted as
# the GL passes' CPU time); __GL_YIELD=USLEEP makes it sleep instead, so that a core waiting for
# the GPU can run another worker: the same bench with it, and with more workers than cores.
# (Other drivers ignore the variable.)
most=${workers##*,}
more=$(( most * 3 / 2 > most ? most * 3 / 2 : most + 1 ))
step bench_yield 120 env __GL_YIELD=USLEEP stereoforge bench dataset --configs flying \
  --size 960x540 --workers "$most,$more" --count "$count" --backend egl --out "$work/bench_yield"
# the status says whether every step ran: 0 only then, 1 naming the failed ones (their files
# say why)
if [ ${#failed[@]} -gt 0 ]; then
  echo "gpu_check: ${#failed[@]} step(s) failed: ${failed[*]} (see $out/<step>.txt)" >&2
  exit 1
fi
