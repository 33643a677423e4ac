"""Run ``colony ARGS`` and SIGKILL it at a chosen write, as a power loss or the OOM killer would.

``python tests/killpoint.py NAME K MODE ARGS...``: the process kills itself at its K-th (from 1)
write of a file whose name contains NAME ("" for any): an atomic write (``os.replace`` of a
temporary file) or a trajectory append (``particles.output.append_frame``), with the file in
one of three states (MODE):

- ``torn``: the temporary file cut to half its bytes, not yet renamed: a kill in the middle of
  writing a frame, a checkpoint or history.csv; for the trajectory (appended in place), half
  the new frame's bytes at the end and the file's first bytes (its header and index) as before
  the append: a kill in the middle of gsd's flush, which writes the data before the index;
- ``written``: the temporary file complete, not yet renamed;
- ``renamed``: just after the rename (or the append): a kill between two writes.

Exit status: SIGKILL's (-9 seen by the parent) when the K-th write came, otherwise the command's
own (the run had fewer writes than K).
"""

import os
import signal
import sys

if __name__ == "__main__":  # tests/ is not where the packages of these names live
    sys.path.pop(0)


def _die():
    os.kill(os.getpid(), signal.SIGKILL)


def main(name: str, k: int, mode: str, args: list[str]) -> int:
    count = [0]
    real_replace = os.replace

    def replace(src, dst, *a, **kw):
        count[0] += name in os.path.basename(dst)
        if count[0] == k and mode == "torn" and ".tmp" in os.path.basename(src):
            os.truncate(src, os.path.getsize(src) // 2)
            _die()
        if count[0] == k and mode == "torn":  # a rename of a whole file (the checkpoint to
            _die()  # checkpoint.prev.npz) tears nothing: the kill comes before it
        if count[0] == k and mode == "written":
            _die()
        real_replace(src, dst, *a, **kw)
        if count[0] == k:
            _die()

    os.replace = replace
    import particles.output as output  # the trajectory appends in place: tear its new frame

    real_append = output.append_frame

    def append_frame(path, *a, **kw):
        count[0] += name in os.path.basename(path)
        before = open(path, "rb").read() if os.path.exists(path) else b""
        real_append(path, *a, **kw)
        if count[0] == k:
            if mode == "torn":  # the frame's data half appended, its index not yet written
                with open(path, "r+b") as fh:
                    size = os.path.getsize(path)
                    fh.write(before)
                    fh.truncate(len(before) + (size - len(before)) // 2)
            _die()

    output.append_frame = append_frame
    from cases import cli

    return cli.main(args)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4:]))
