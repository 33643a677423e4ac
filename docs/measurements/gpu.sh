#!/bin/bash
# The GPU measurement of issue 44 (docs/benchmarks.md, "Contacts on a GPU"), one device call:
# the memory bandwidth on 1-16 cores (stream.py: B(16), the cap of the CPU's speed-up), the
# CUDA solver's tests on the card, then gpu_solve.py at the committed 1e5-cell checkpoint.
# Its machine (the workplace's H200) has numba, numba-cuda and CUDA's compiler, not the
# package's other needs: carry them as wheels for Python 3.12 in .whl (gsd, scikit-fem, pyamg,
# triangle, meshio; the device README says how), e.g.
#   run(command="bash docs/measurements/gpu.sh", carry=[".whl", "runs/state_104993"], timeout_s=540)
set -o pipefail
# The 1e5-cell state (leg 1 of the radius-260 colony, in git history, not in the tree): made by
#   mkdir -p runs/state_104993 && for F in checkpoint.npz history.csv config.json; do git show \
#     df85091:cases/data/colony_260/particles_resume/$F > runs/state_104993/$F; done
# before the call, and carried: carry=[".whl", "runs/state_104993"].
test -f runs/state_104993/checkpoint.npz || { echo "gpu.sh: no runs/state_104993 (see above)"; exit 2; }
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl && export PYTHONPATH=/tmp/site:$PWD || exit
export NUMBA_ENABLE_CUDASIM=0 PYTHONUNBUFFERED=1 OUT=${OUT:-/tmp/out}
mkdir -p "$OUT"
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv | tee "$OUT/gpu.txt"
python3 -c "import numba, numba_cuda; print('numba', numba.__version__, 'numba-cuda',
numba_cuda.__version__)" | tee -a "$OUT/gpu.txt"
timeout 60 python3 docs/measurements/stream.py --threads 1 2 4 8 16 2>&1 | tee "$OUT/stream.txt"
timeout 150 python3 -m pytest -q -p no:cacheprovider tests/particles/test_cuda_solver.py 2>&1 \
    | tee "$OUT/tests.txt"
timeout 300 python3 docs/measurements/gpu_solve.py \
    runs/state_104993/checkpoint.npz --threads 1 2 16 --steps 3 2>&1 \
    | tee "$OUT/solve.txt"
