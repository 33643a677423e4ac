"""Damaged outputs given to ``colony plot|movie`` and ``colony continuum --from-particles``.

A catalogue (issue 28): a bit-flipped or cut ``trajectory.gsd`` (the gsd library crashed the
process, asked for terabytes or filled the memory; ``--from-particles`` used a damaged last
frame), damaged VTU frames and ``fields.pvd``, a half ``history.csv``, damaged
``particles.csv``, ``profile.csv`` and ``handoff.json``, bad movie options; and how pictures
and movies are written: never through a symbolic link, never half, never into a folder a run
still writes into. Each refusal is exit status 2 and one line naming the file, and every file
and folder around is as it was (hashed before and after).

One small run of each engine is made per module and copied into each test's folder.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest

from cases import cli, rundir
from tests.cases.test_faults import SMALL_CONTINUUM, SMALL_PARTICLES, one_line_error


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, Path]:
    """One small finished run of each engine: {"continuum": folder, "particles": folder}."""
    root = tmp_path_factory.mktemp("runs")
    made = {}
    for engine, args in (("continuum", SMALL_CONTINUUM), ("particles", SMALL_PARTICLES)):
        made[engine] = root / engine
        assert cli.main([*args, "--out", str(made[engine])]) == 0
    return made


@pytest.fixture
def area(runs, tmp_path) -> Path:
    """A folder holding a copy of both runs and a user's files beside them."""
    for engine, folder in runs.items():
        shutil.copytree(folder, tmp_path / engine, symlinks=True)
    (tmp_path / "notes.txt").write_text("a user's notes")
    (tmp_path / "thesis").mkdir()
    (tmp_path / "thesis" / "figure.png").write_bytes(b"years of work")
    return tmp_path


def snapshot(root: Path, skip: Path | None = None) -> dict:
    """Every entry under ``root`` (but ``skip``): folders, links and the sha256 of files."""
    found = {}
    for p in sorted(root.rglob("*")):
        if skip is not None and (p == skip or skip in p.parents):
            continue
        if p.is_symlink():
            found[p.relative_to(root)] = ("link", os.readlink(p))
        elif p.is_dir():
            found[p.relative_to(root)] = "folder"
        else:
            found[p.relative_to(root)] = hashlib.sha256(p.read_bytes()).hexdigest()
    return found


def refused(colony, area: Path, args, *needles) -> None:
    """``colony ARGS`` ends with one line holding ``needles``, exit 2, and nothing changed."""
    before = snapshot(area)
    status, err = colony(*args)
    one_line_error(status, err, *needles)
    assert snapshot(area) == before


# --------------------------------------------------------------------------- damage


def gsd_chunks(path: Path) -> dict[tuple[int, str], tuple[int, int]]:
    """{(frame, chunk name): (offset of its index entry, offset of its data)} of a GSD file."""
    data = path.read_bytes()
    index_at, n_index, names_at, n_names = struct.unpack_from("<QQQQ", data, 8)
    names = data[names_at:names_at + 64 * n_names].split(b"\0")
    found = {}
    for k in range(n_index):
        frame, _, location, _, ident, _, _ = struct.unpack_from("<QQqIHBB", data, index_at + 32 * k)
        if location == 0:
            break
        found[frame, names[ident].decode()] = (index_at + 32 * k, location)
    return found


def last_frame_chunk(path: Path, name: str) -> tuple[int, int]:
    """(index entry offset, data offset) of chunk ``name`` in the last frame that has it."""
    chunks = gsd_chunks(path)
    frame = max(f for f, n in chunks if n == name)
    return chunks[frame, name]


def flip(path: Path, offset: int, mask: int = 0x80) -> None:
    """Flip the bits ``mask`` of the byte at ``offset``."""
    data = bytearray(path.read_bytes())
    data[offset] ^= mask
    path.write_bytes(bytes(data))


def put(path: Path, offset: int, raw: bytes) -> None:
    data = bytearray(path.read_bytes())
    data[offset:offset + len(raw)] = raw
    path.write_bytes(bytes(data))


def cut(path: Path, keep: float = 0.5) -> None:
    data = path.read_bytes()
    path.write_bytes(data[:int(len(data) * keep)])


#: Damage of trajectory.gsd: name -> (change of the file, what the message says).
GSD_DAMAGE = {
    # the index's entry count, top byte: gsd's reader crashed the process (segfault)
    "index count": (lambda p: flip(p, 23), "its index lies outside the file"),
    # a chunk's row count N, top byte: "Unable to allocate 1020 TiB"
    "chunk rows": (lambda p: flip(p, gsd_chunks(p)[0, "log/particles/length"][0] + 15),
                   "lies outside the file"),
    # frame 0's particle count: gsd.hoomd filled 2^31 default rows until the kernel killed it
    "particle count": (lambda p: flip(p, gsd_chunks(p)[0, "particles/N"][1] + 3),
                       "claims 2147483649 particles"),
    # the last frame's first length negative (sign bit): --from-particles used such a frame
    "last length": (lambda p: flip(p, last_frame_chunk(p, "log/particles/length")[1] + 3),
                    "has lengths that are not positive"),
    "last position": (lambda p: put(p, last_frame_chunk(p, "particles/position")[1],
                                    struct.pack("<f", np.nan)),
                      "has centres that are not finite"),
    "last orientation": (lambda p: put(p, last_frame_chunk(p, "particles/orientation")[1],
                                       struct.pack("<f", 7.0)),
                         "orientations that are not unit quaternions"),
    # the type code of an index entry (byte 30 of its 32)
    "chunk type": (lambda p: put(p, last_frame_chunk(p, "particles/position")[0] + 30, b"\xc8"),
                   "has an unknown data type"),
    # read by gsd.hoomd, which refuses it: its error becomes the one line
    "schema version": (lambda p: flip(p, 42), "gsd cannot read it (RuntimeError: Incompatible"),
    "cut": (cut, "is damaged"),
    "empty": (lambda p: p.write_bytes(b""), "shorter than a GSD header"),
    "random bytes": (lambda p: p.write_bytes(np.random.default_rng(0).bytes(4096)),
                     "not a GSD file"),
}


def gsd_commands(area: Path) -> dict[str, list[str]]:
    """The commands that read a particle run's trajectory.gsd."""
    run = str(area / "particles")
    return {
        "plot": ["plot", run, "--out", str(area / "pictures")],
        "movie": ["movie", run, "--quiet"],
        "from-particles": ["continuum", "--from-particles", run, "--radius", "3", "--set",
                           "n_nodes=200", "--quiet", "--out", str(area / "handed")],
    }


@pytest.mark.parametrize("command", ["plot", "movie", "from-particles"])
@pytest.mark.parametrize("damage", list(GSD_DAMAGE))
def test_damaged_trajectory(colony, area, damage, command):
    change, what = GSD_DAMAGE[damage]
    (area / "particles" / "particles.csv").unlink()  # plot: the picture from the trajectory
    change(area / "particles" / "trajectory.gsd")
    refused(colony, area, gsd_commands(area)[command], "trajectory.gsd is damaged", what)


def test_undamaged_trajectory_works(colony, area):
    """The commands of test_damaged_trajectory on the undamaged copy (the control)."""
    (area / "particles" / "particles.csv").unlink()
    for args in gsd_commands(area).values():
        status, err = colony(*args)
        assert status == 0, err
    assert (area / "pictures" / "colony.png").is_file()
    assert (area / "particles" / "movie.mp4").is_file()
    assert json.loads((area / "handed" / "handoff.json").read_text())["n_particles"] >= 3


def last_vtu(run: Path) -> Path:
    return sorted((run / "fields").glob("*.vtu"))[-1]


def rewrite_vtu(path: Path, change) -> None:
    """Read a VTU with meshio, ``change(mesh)``, write it back (well-formed, bad values)."""
    import meshio

    mesh = meshio.read(path)
    change(mesh)
    meshio.write(path, mesh)


def nan_g(mesh) -> None:
    mesh.point_data["G"] = np.asarray(mesh.point_data["G"], dtype=float).copy()
    mesh.point_data["G"][0] = np.nan


def far_triangle(mesh) -> None:
    mesh.cells[0].data[0, 0] = len(mesh.points) + 5


#: Damage of a continuum run (its last VTU frame, or fields.pvd): name -> (change, message).
CONTINUUM_DAMAGE = {
    "vtu cut": (lambda r: cut(last_vtu(r)), "meshio cannot read it"),
    "vtu flipped": (lambda r: flip(last_vtu(r), 700, 0x04), "meshio cannot read it"),
    "vtu empty": (lambda r: last_vtu(r).write_bytes(b""), "meshio cannot read it"),
    "vtu G not finite": (lambda r: rewrite_vtu(last_vtu(r), nan_g),
                         "point data G are not finite"),
    "vtu triangles": (lambda r: rewrite_vtu(last_vtu(r), far_triangle),
                      "triangles name points it does not have"),
    "pvd outside": (lambda r: (r / "fields.pvd").write_text(
        (r / "fields.pvd").read_text().replace('file="fields/', 'file="../../fields/')),
        "fields.pvd is damaged: it names"),
    "pvd not xml": (lambda r: cut(r / "fields.pvd", 0.6), "fields.pvd is damaged: not XML"),
}


@pytest.mark.parametrize("command", ["plot", "movie"])
@pytest.mark.parametrize("damage", list(CONTINUUM_DAMAGE))
def test_damaged_continuum_frames(colony, area, damage, command):
    change, what = CONTINUUM_DAMAGE[damage]
    run = area / "continuum"
    name = "fields.pvd" if damage.startswith("pvd") else last_vtu(run).name
    change(run)
    args = ["plot", str(run)] if command == "plot" else ["movie", str(run), "--quiet"]
    refused(colony, area, args, name, what)


def garbage(path: Path) -> None:
    path.write_bytes(bytes(range(256)) * 8)


def not_a_number(column: str):
    """Replace the value of ``column`` in the last row of a CSV by 'x2.5'."""
    def change(path: Path) -> None:
        lines = path.read_text().splitlines()
        k = lines[0].split(",").index(column)
        cells = lines[-1].split(",")
        cells[k] = "x2.5"
        path.write_text("\n".join([*lines[:-1], ",".join(cells)]) + "\n")
    return change


#: Damage of a CSV given to ``colony plot``: name -> (engine, file, change, message).
CSV_DAMAGE = {
    "history cut": ("particles", "history.csv", cut, "is damaged or cut short: line"),
    "history cut (continuum)": ("continuum", "history.csv", cut,
                                "is damaged or cut short: line"),
    "history binary": ("continuum", "history.csv", garbage, "is damaged: not text"),
    "history radius": ("particles", "history.csv", not_a_number("radius"),
                       "has no finite t and radius"),
    "particles length": ("particles", "particles.csv", not_a_number("length"),
                         "has lengths that are not finite"),
    "particles column": ("particles", "particles.csv",
                         lambda p: p.write_text(p.read_text().replace("theta", "phi", 1)),
                         "no column theta"),
    "particles cut": ("particles", "particles.csv", lambda p: cut(p, 0.7), "cut short"),
    "profile column": ("continuum", "profile.csv",
                       lambda p: p.write_text(p.read_text().replace("r,", "radius,", 1)),
                       "no column r"),
}


@pytest.mark.parametrize("damage", list(CSV_DAMAGE))
def test_damaged_csv(colony, area, damage):
    engine, name, change, what = CSV_DAMAGE[damage]
    change(area / engine / name)
    refused(colony, area, ["plot", str(area / engine)], name, what)


@pytest.mark.parametrize("content,what", [("[1, 2]", "not a JSON object"),
                                          ('{"particle_run": ', "handoff.json is damaged")])
def test_damaged_handoff_record_of_a_stopped_run(colony, area, content, what):
    """A stopped hand-off run whose handoff.json is damaged: refused (was AttributeError)."""
    stage = area / "handed.partial"
    stage.mkdir()
    (stage / "checkpoint.npz").write_bytes(b"")
    (stage / "handoff.json").write_text(content)
    args = gsd_commands(area)["from-particles"]
    refused(colony, area, args, "handoff.json", what)


# --------------------------------------------------------------------------- movie options


@pytest.mark.parametrize("option,what", [
    (["--fps", "1e308"], "--fps must be a number from 0.1 to 1000"),
    (["--fps", "0"], "--fps must be"),
    (["--fps", "-3"], "--fps must be"),
    (["--fps", "nan"], "--fps must be"),
    (["--fps", "1e-300"], "--fps must be"),
    (["--max-frames", "0"], "--max-frames must be"),
    (["--max-frames", "-7"], "--max-frames must be"),
    (["--max-frames", "100000000000000000000"], "--max-frames must be from 1"),
    (["--out", "{area}/thesis"], "is a folder"),
    (["--out", "{area}/movie.txt"], "must end in .mp4"),
    (["--out", "{area}/notes.txt"], "must end in .mp4"),
])
def test_bad_movie_options(colony, area, option, what):
    option = [o.format(area=area) for o in option]
    refused(colony, area, ["movie", str(area / "continuum"), "--quiet", *option], what)


# --------------------------------------------------------------------------- writes


def test_pictures_and_movie_replace_links_never_write_through_them(colony, area):
    """Links named as the outputs point outside: the links are replaced, the targets kept."""
    target = area / "thesis" / "figure.png"
    names = {"continuum": ("mean_length.png", "radius.png", "profile.png", "movie.mp4"),
             "particles": ("colony.png", "radius.png", "profile.png", "movie.mp4")}
    for engine, outputs in names.items():
        for name in outputs:
            (area / engine / name).unlink(missing_ok=True)
            (area / engine / name).symlink_to(target)
    for engine in names:
        outside = snapshot(area, skip=area / engine)
        assert colony("plot", str(area / engine))[0] == 0
        assert colony("movie", str(area / engine), "--quiet")[0] == 0
        assert snapshot(area, skip=area / engine) == outside
        for name in names[engine]:
            path = area / engine / name
            assert not path.is_symlink() and path.is_file(), path
            head = path.read_bytes()[:8]
            assert head[:4] == b"\x89PNG" if name.endswith(".png") else head[4:] == b"ftyp"
        assert not list((area / engine).glob("*.tmp"))
    assert target.read_bytes() == b"years of work"


@pytest.mark.parametrize("command", ["plot", "movie"])
def test_output_folder_that_is_a_link_is_refused(colony, area, command):
    link = area / "link"
    link.symlink_to(area / "thesis")
    args = (["plot", str(area / "particles"), "--out", str(link)] if command == "plot" else
            ["movie", str(area / "particles"), "--quiet", "--out", str(link / "m.mp4")])
    refused(colony, area, args, str(link), "symbolic link")


@pytest.mark.parametrize("command", ["plot", "movie", "plot --out", "movie --out"])
def test_a_folder_a_run_is_writing_into_is_refused(colony, area, command):
    """``DIR.partial`` of a running run (its lock held): plot and movie refuse to write there."""
    stage = area / "run.partial"
    shutil.copytree(area / "continuum", stage)
    source = stage if "--out" not in command else area / "continuum"
    args = [command.split()[0], str(source)]
    if command == "plot --out":
        args += ["--out", str(stage)]
    if command == "movie --out":
        args += ["--out", str(stage / "movie.mp4")]
    if command.startswith("movie"):
        args.append("--quiet")
    with rundir.hold(stage):
        refused(colony, area, args, str(stage), "is in use")


def test_a_folder_in_place_of_a_picture_is_refused_before_anything_is_replaced(colony, area):
    run = area / "particles"
    (run / "profile.png").mkdir()
    refused(colony, area, ["plot", str(run)], "profile.png is a folder")


def test_a_failed_movie_keeps_the_old_one_whole(colony, area):
    """A frame damaged in the middle of the movie: the old movie.mp4 stays, no part is left."""
    run = area / "continuum"
    (run / "movie.mp4").write_bytes(b"the old movie")
    vtus = sorted((run / "fields").glob("*.vtu"))
    assert len(vtus) >= 3
    cut(vtus[1])
    refused(colony, area, ["movie", str(run), "--quiet"], vtus[1].name, "is damaged")
    assert (run / "movie.mp4").read_bytes() == b"the old movie"


def test_plot_out_that_is_a_file_or_new_folder_left_empty(colony, area):
    refused(colony, area, ["plot", str(area / "particles"), "--out", str(area / "notes.txt")],
            "notes.txt is a file")
    cut(area / "particles" / "history.csv")  # fails after --out was created: it is removed
    refused(colony, area, ["plot", str(area / "particles"), "--out", str(area / "new" / "o")],
            "history.csv")
