"""Any user, any disk, any signal: what the twin promises where it meets its environment (README,
"Reliability"). An unprivileged user or a read-only install still runs every command; a full disk
at an output ends in one line naming the file; two names for one file share one lock; a stopped
sweep keeps its finished runs; an unreadable input is refused in one line; a run too short to judge
is not PASSED."""

from __future__ import annotations

import builtins
import errno
import io
import json
import logging
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
HEAVY = ("numba", "numpy", "mujoco", "rerun", "scipy", "pinocchio", "matplotlib")  # what --help must not load


# --- any user: an unwritable home, a read-only install ------------------------------------------
def read_only_tree() -> list[str] | None:
    """A command prefix that runs its command with the source tree read-only at its own path (a
    bind mount in a mount namespace of its own, so nothing outside sees it), or None where that
    cannot be done (not root, no `unshare`)."""
    if not hasattr(os, "geteuid") or os.geteuid() != 0 or not shutil.which("unshare"):
        return None
    script = 'mount --bind "$1" "$1" && mount -o remount,ro,bind "$1" && shift && exec "$@"'
    prefix = ["unshare", "--mount", "sh", "-c", script, "sh", str(ROOT)]
    probe = subprocess.run([*prefix, "sh", "-c", f"! touch {ROOT}/.twin-ro-probe"], capture_output=True)
    return prefix if probe.returncode == 0 else None


def seed_private_cache(tmp: Path) -> Path:
    """The private fallback cache under `tmp` that the child will choose, holding what this
    process's cache holds for the current sources (so the child loads the compiled laws instead of
    spending half a minute compiling them again; it compiles what is missing)."""
    import scenarios.runner  # noqa: F401 - every law the run compiles, so their cache keys are known
    from pneumatics import _jit

    private = tmp / f"pneumatic-arm-twin-{os.getuid()}"
    private.mkdir(mode=0o700)
    if _jit._CACHE_ROOT is not None:
        for key in set(_jit._cache_keys.values()):
            if (Path(_jit._CACHE_ROOT) / key).is_dir():
                shutil.copytree(Path(_jit._CACHE_ROOT) / key, private / key)
    return private


def test_a_user_who_can_write_neither_home_nor_install_runs_the_twin(tmp_path):
    """HOME is a file (nothing can be made under it, by root neither) and the source tree is
    mounted read-only: `--version` and `--help` load nothing heavy, and a run caches the compiled
    laws in a private folder in the temporary folder, which it says once, then passes. Before, every
    command ended in numba's "cannot cache function 'lag_factors': no locator available"."""
    home = tmp_path / "home"
    home.write_text("not a folder")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    private = seed_private_cache(tmp)
    prefix = read_only_tree() or []
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "TWIN_JIT_CACHE")}
    env.update(HOME=str(home), TMPDIR=str(tmp), PYTHONPATH=str(ROOT), MPLCONFIGDIR=str(tmp / "mpl"))

    def twin(*args: str, importtime: bool = False) -> subprocess.CompletedProcess:
        python = [sys.executable, *(["-X", "importtime"] if importtime else []), "-m", "twin_cli.cli"]
        return subprocess.run([*prefix, *python, *args], env=env, cwd=tmp, capture_output=True, text=True)

    for args in (["--version"], ["--help"], ["run", "--help"], ["gap", "diagnose", "--help"]):
        proc = twin(*args, importtime=True)
        assert proc.returncode == 0, proc.stderr[-2000:]
        loaded = {line.split("|")[-1].strip().split(".")[0] for line in proc.stderr.splitlines() if "|" in line}
        assert not loaded & set(HEAVY), (args, loaded & set(HEAVY))
    scenario = ROOT / "scenarios" / "wrist_closed_loop_60deg.toml"
    proc = twin("run", str(scenario), "--duration", "0.3", "--json")
    assert proc.returncode in (0, 1) and "Traceback" not in proc.stderr, proc.stderr[-2000:]
    said = [line for line in proc.stderr.splitlines() if "compiled-code cache" in line]
    assert len(said) == 1 and str(private) in said[0] and str(home) in said[0], proc.stderr
    assert list(private.iterdir())  # the cache is there
    if prefix:  # nothing was written into the read-only tree (the mount would have refused it)
        assert not (ROOT / ".twin-ro-probe").exists()


def test_the_cache_falls_back_to_a_private_folder_then_to_memory(tmp_path, monkeypatch, caplog):
    """cache_root: the user's cache if it can be written; else a folder of the user's own in the
    temporary folder, never one someone else made or can write (numba loads pickled code from it);
    else None, compiling in memory, said once and inherited by child processes silently."""
    from pneumatics import _jit

    afile = tmp_path / "afile"
    afile.write_text("")
    for name in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "TWIN_JIT_CACHE"):
        # set, then removed: monkeypatch then restores each as it was, and so takes back the
        # TWIN_JIT_CACHE that cache_root sets below (left set, every later child process of the
        # suite compiled every law afresh, in memory: minutes a process)
        monkeypatch.setenv(name, "")
        monkeypatch.delenv(name)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert _jit.cache_root() == str(tmp_path / "home" / ".cache" / "pneumatic-arm-twin")
    monkeypatch.setenv("HOME", str(afile))
    shared = tmp_path / "shared"
    shared.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(shared))
    private = shared / f"pneumatic-arm-twin-{os.getuid()}"
    with caplog.at_level(logging.WARNING):
        assert _jit.cache_root() == str(private)
    assert private.stat().st_mode & 0o777 == 0o700 and "caching it in" in caplog.text
    private.chmod(0o777)  # someone else could write it: not used
    if os.geteuid() == 0:
        private.chmod(0o700)
        os.chown(private, 65534, 65534)  # made by someone else: not used
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        assert _jit.cache_root() is None
        assert os.environ["TWIN_JIT_CACHE"] == _jit.IN_MEMORY
        assert _jit.cache_root() is None  # a second time (a child process): nothing said
    assert len(caplog.records) == 1 and "compiling in memory" in caplog.text


def test_without_a_cache_folder_the_laws_compile_in_memory(monkeypatch):
    from pneumatics import _jit

    if _jit.NO_JIT:
        pytest.skip("TWIN_NO_JIT=1: nothing is compiled")
    monkeypatch.setattr(_jit, "_CACHE_ROOT", None)

    def twice(x):
        return 2.0 * x

    compiled = _jit.njit(twice)
    assert compiled(1.5) == 3.0 and type(compiled._cache).__name__ == "NullCache"


# --- unreadable inputs --------------------------------------------------------------------------
PROBE = """
import contextlib, io, json, sys
from twin_cli.cli import main
said = []
for argv in json.loads(sys.argv[1]):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    said.append([code, err.getvalue()])
print(json.dumps(said))
"""


def as_a_user_bound_by_permissions() -> list[str]:
    """A command prefix under which file permissions hold: none for a user, and for root a
    child without the capabilities that let root read any file (setpriv), or a skip."""
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        return []
    if not shutil.which("setpriv"):
        pytest.skip("root without setpriv: permissions do not bind root here")
    caps = "-dac_override,-dac_read_search"
    return ["setpriv", f"--bounding-set={caps}", f"--inh-caps={caps}"]


def test_inputs_this_user_cannot_read_are_refused_in_one_line(tmp_path):
    """A campaign's run file, its campaign.toml, a campaign folder that cannot be searched, a
    scenario, an MCAP log, a model and a recording that this user may not read are each refused
    with exit 2 and one line naming the file and the cause (the run file, and campaign.toml in an
    unsearchable folder, ended in PermissionError tracebacks)."""
    from test_inputs import RIG, campaign

    prefix = as_a_user_bound_by_permissions()
    open_run = campaign(tmp_path / "run_unreadable")
    (open_run / "a.csv").chmod(0)
    toml = campaign(tmp_path / "toml_unreadable")
    (toml / "campaign.toml").chmod(0)
    shut = campaign(tmp_path / "shut")
    scenario = tmp_path / "s.toml"
    scenario.write_text(RIG)
    mcap, model, rrd = tmp_path / "run.mcap", tmp_path / "arm.xml", tmp_path / "run.rrd"
    for f in (scenario, mcap, model, rrd):
        f.write_text("")
        f.chmod(0)
    out = tmp_path / "out"
    probes = {
        str(open_run / "a.csv"): ["gap", "diagnose", str(open_run), "--out", str(out)],
        str(toml / "campaign.toml"): ["gap", "diagnose", str(toml), "--out", str(out)],
        str(shut / "campaign.toml"): ["gap", "diagnose", str(shut), "--out", str(out)],
        str(scenario): ["run", str(scenario)],
        str(mcap): ["plot", str(mcap), "--out", str(tmp_path / "a.png")],
        f"--model {model}": [
            "replay",
            str(tmp_path / "x.mcap"),
            "--rrd",
            str(rrd.with_name("y.rrd")),
            "--model",
            str(model),
        ],
        str(rrd): ["view", str(rrd)],
    }
    shut.chmod(0o600)  # the folder's entries cannot be looked up
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    argvs = json.dumps(list(probes.values()))
    try:
        proc = subprocess.run([*prefix, sys.executable, "-c", PROBE, argvs], env=env, capture_output=True, text=True)
    finally:
        shut.chmod(0o755)
    assert proc.returncode == 0, proc.stderr[-3000:]
    for (needle, argv), (code, err) in zip(probes.items(), json.loads(proc.stdout), strict=True):
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1, (argv, code, err)
        assert needle in lines[0] and "Permission denied" in lines[0], (argv, lines[0])
    assert not out.exists()


# --- runs cut short -------------------------------------------------------------------------------
def test_a_run_too_short_to_judge_is_not_passed_and_a_cut_sweep_says_what_was_not_judged(tmp_path, capsys):
    """`twin run --duration 1e-4` judged nothing and printed "PASSED"; now it says NOT JUDGED and
    exits 1. A sweep cut before the plan's end names, in its table, the criteria it did not judge
    (column not_judged, their passed cells empty) and passes a run only on what it judged."""
    import csv

    from twin_cli.cli import main

    text = (ROOT / "scenarios" / "wrist_closed_loop_60deg.toml").read_text()
    only_final = tmp_path / "final.toml"
    only_final.write_text(text)
    assert main(["run", str(only_final), "--duration", "1e-4"]) == 1
    out = capsys.readouterr().out
    assert "NOT JUDGED (cut short before any criterion could be judged)" in out and "PASSED" not in out
    both = tmp_path / "both.toml"  # a criterion judged at any time beside one judged at the plan's end
    both.write_text(text + '\n[[criteria]]\nkind = "prediction_error_deg"\njoint = "wrist_pitch"\nmax = 90.0\n')
    table = tmp_path / "sweep.csv"
    for scenario in (only_final, both):
        main(["sweep", str(scenario), "--workers", "1", "--duration", "0.3", "--out", str(tmp_path / "sweep.json")])
        (row,) = csv.DictReader(table.open())
        assert row["not_judged"] == "final_error_deg[wrist_pitch]" and row["final_error_deg[wrist_pitch].passed"] == ""
        assert row["passed"] == str(scenario == both)  # the judged criterion held; nothing judged is no pass
        assert "1 cut short with criteria not judged" in capsys.readouterr().out


# --- one lock per file, whatever its name -------------------------------------------------------
def test_no_alias_lets_two_runs_write_one_file_or_folder(tmp_path, monkeypatch, capsys):
    """Through a symbolic link to the file, to a folder above it, `..`, a relative path, or (as
    root) a bind mount of its folder, a second writer meets the first one's lock. Before, the lock
    was keyed by the path as given: two runs through a link both wrote, and one's log was lost."""
    from twin_cli.cli import main
    from twin_plumbing.errors import UserError
    from twin_plumbing.outputs import OutputLock

    real = tmp_path / "real"
    real.mkdir()
    (tmp_path / "folder_link").symlink_to(real)
    (real / "run.mcap").write_bytes(b"")
    (tmp_path / "file_link.mcap").symlink_to(real / "run.mcap")
    (real / "sub").mkdir()
    monkeypatch.chdir(tmp_path)
    aliases = [
        tmp_path / "folder_link" / "run.mcap",
        tmp_path / "file_link.mcap",
        real / "sub" / ".." / "run.mcap",
        Path("real/run.mcap"),
        tmp_path / "folder_link",  # the folder itself, as --out DIR
    ]
    mounted = tmp_path / "mounted"
    if hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("mount"):
        mounted.mkdir()
        if subprocess.run(["mount", "--bind", str(real), str(mounted)], capture_output=True).returncode == 0:
            aliases.append(mounted / "run.mcap")  # the same folder under another path, no link to resolve
    try:
        for alias in aliases:
            first = real if alias.name == "folder_link" else real / "run.mcap"
            with (
                OutputLock([first]),
                pytest.raises(UserError, match="another run is writing this file now"),
                OutputLock([alias]),
            ):
                pass
        with OutputLock([real / "run.mcap"]):  # and the command line says so in one line, exit 2
            scenario = ROOT / "scenarios" / "wrist_closed_loop_60deg.toml"
            assert main(["run", str(scenario), "--mcap", str(tmp_path / "file_link.mcap")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "another run is writing this file now" in err[0], err
    finally:
        if mounted / "run.mcap" in aliases:
            subprocess.run(["umount", str(mounted)], check=True)
    assert (real / "run.mcap").read_bytes() == b""  # the refused run wrote nothing


# --- a full disk at any output ------------------------------------------------------------------
@pytest.fixture
def small_disk(tmp_path):
    """`fill(free_bytes)`: a real small file system (tmpfs, as root) filled to leave that much
    free, its folder returned; skipped where one cannot be mounted."""
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = (
        hasattr(os, "geteuid")
        and os.geteuid() == 0
        and subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=4m", "tmpfs", str(disk)], capture_output=True
        ).returncode
        == 0
    )
    if not mounted:
        pytest.skip("a small file system needs root to mount (tmpfs)")

    def fill(free_bytes: int) -> Path:
        with open(disk / ".filler", "wb") as f:
            f.write(b"\0" * max(shutil.disk_usage(disk).free - free_bytes, 0))
        return disk

    try:
        yield fill
    finally:
        subprocess.run(["umount", "-l", str(disk)], check=True)


class _Cut:
    """A file opened for writing on an emulated small disk: it takes what the disk has left, then
    fails as a full disk does, OSError(ENOSPC) naming no file; anything else goes to the file."""

    def __init__(self, f, disk: dict):
        self._f, self._disk = f, disk

    def write(self, data):
        room = self._disk["free"]
        if len(data) > room:
            self._f.write(data[:room])
            self._disk["free"] = 0
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self._disk["free"] -= len(data)
        return self._f.write(data)

    def writelines(self, lines):
        for line in lines:
            self.write(line)

    def __getattr__(self, name):
        return getattr(self._f, name)

    def __iter__(self):
        return iter(self._f)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._f.close()


def emulated_small_disk(disk: Path, free_bytes: int, monkeypatch) -> Path:
    """`disk`, a folder whose files (opened by Python's `open`, `Path.open`, `os.fdopen`: every
    output of paper, study, bench, sweep and plot) share `free_bytes` and then fail with ENOSPC:
    a full disk where none can be mounted. Writes from compiled code (rerun's) are not caught."""
    disk.mkdir(exist_ok=True)
    state = {"free": free_bytes}
    real_open = io.open

    def opened(file, mode="r", *args, **kwargs):
        f = real_open(file, mode, *args, **kwargs)
        name = os.readlink(f"/proc/self/fd/{file}") if isinstance(file, int) else os.path.realpath(file)
        writes = any(c in mode for c in "wax+")
        return _Cut(f, state) if writes and Path(name).is_relative_to(disk.resolve()) else f

    if not Path("/proc/self/fd").is_dir():
        pytest.skip("the emulated disk names a descriptor's file through /proc")
    monkeypatch.setattr(io, "open", opened)
    monkeypatch.setattr(builtins, "open", opened)
    return disk


@pytest.fixture(params=["tmpfs", "writer"])
def full_disk(request, tmp_path, monkeypatch):
    """`fill(free_bytes)`, a folder on a disk with that much left: a real small file system
    (small_disk, where one can be mounted), and a writer that fails with ENOSPC (anywhere)."""
    if request.param == "tmpfs":
        return request.getfixturevalue("small_disk")
    return lambda free_bytes: emulated_small_disk(tmp_path / "disk", free_bytes, monkeypatch)


def errors_of(err: str) -> list[str]:
    """What a command said on stderr besides its progress bars (tqdm's, rewritten in place)."""
    lines = [line for line in err.replace("\r", "\n").splitlines() if line.strip() and "it/s]" not in line]
    assert "Traceback" not in err and all(line.startswith("twin: ") for line in lines), err
    return lines


def test_a_full_disk_under_the_logs_names_each_damaged_one_and_never_calls_it_written(small_disk, capsys):
    """Both logs of a run on a disk that fills during it: exit 2, the run's summary printed, and
    each log either whole (rerun's footer, the MCAP's) or named as not written whole in one line
    with the cause; it is kept. Before, the .rrd was reported written though it had no footer."""
    from twin.mcap_log import read_mcap
    from twin_cli.cli import main

    disk = small_disk(96 * 1024)
    rrd, mcap = disk / "run.rrd", disk / "run.mcap"
    scenario = ROOT / "scenarios" / "wrist_closed_loop_60deg.toml"
    assert main(["run", str(scenario), "--duration", "3", "--rrd", str(rrd), "--mcap", str(mcap)]) == 2
    out, err = capsys.readouterr()
    assert "wrist_closed_loop_60deg: PASSED" in out
    failed = errors_of(err)
    assert failed and all("No space left on device" in line for line in failed)
    import rerun as rr

    for path, label in ((rrd, "rerun recording"), (mcap, "MCAP log")):
        assert path.exists()  # kept: what it holds is readable up to the cut
        said_damaged = any(line.startswith(f"twin: error: {path}:") for line in failed)
        assert (f"{label}: {path} NOT written whole" in out) == said_damaged
        if not said_damaged:  # said to be written: it is whole
            if path == rrd:
                with warnings.catch_warnings():
                    warnings.simplefilter("error")
                    rr.chunk.RrdReader(rrd)
            else:
                assert read_mcap(mcap)[1]["recovery"]["complete"]
    assert any(line.startswith(f"twin: error: {rrd}: damaged") for line in failed)


def test_a_full_disk_under_a_table_or_a_picture_keeps_it_elsewhere_and_exits_2(
    full_disk, tmp_path, monkeypatch, capsys
):
    """`twin sweep --out` and `twin plot --out` on a full disk: the result is saved in the working
    folder instead, said in one line naming the place asked for and the cause, exit 2."""
    from twin_cli.cli import main

    scenario = ROOT / "scenarios" / "wrist_closed_loop_60deg.toml"
    mcap = tmp_path / "run.mcap"
    assert main(["run", str(scenario), "--duration", "0.5", "--mcap", str(mcap)]) == 1
    disk = full_disk(0)
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    capsys.readouterr()
    for argv, asked in (
        (
            ["sweep", str(scenario), "--duration", "0.3", "--workers", "1", "--out", str(disk / "s.json")],
            disk / "s.json",
        ),
        (["plot", str(mcap), "--out", str(disk / "a.png")], disk / "a.png"),
    ):
        assert main(argv) == 2
        said = errors_of(capsys.readouterr().err)
        assert all(str(asked) in line or str(asked.with_suffix(".csv")) in line for line in said), said
        assert all("No space left on device" in line for line in said)
        kept = [Path(line.split("saved them to ")[1].split(" instead")[0]) for line in said]
        assert kept and all(p.parent == work and p.stat().st_size > 0 for p in kept)
    assert not [p for p in disk.iterdir() if p.name != ".filler"]  # nothing half-written left there


def test_a_full_disk_under_a_replay_or_a_report_folder_names_the_file_and_keeps_the_rest(small_disk, tmp_path, capsys):
    """`twin replay --rrd` says its recording is damaged; `twin gap diagnose --out` names the file it
    could not write, removes it (cut short) and keeps the files written before it beside DIR; exit 2."""
    from test_inputs import campaign

    from twin_cli.cli import main

    scenario = ROOT / "scenarios" / "wrist_closed_loop_60deg.toml"
    mcap = tmp_path / "run.mcap"
    assert main(["run", str(scenario), "--duration", "2", "--mcap", str(mcap)]) == 0
    disk = small_disk(40 * 1024)
    capsys.readouterr()
    assert main(["replay", str(mcap), "--rrd", str(disk / "r.rrd")]) == 2
    (line,) = errors_of(capsys.readouterr().err)
    # too little room for a recording's start: refused before rerun opens it (its sink can block there)
    assert f"{disk / 'r.rrd'}: not written" in line and "No space left on device" in line
    assert not (disk / "r.rrd").exists()
    assert main(["gap", "diagnose", str(campaign(tmp_path / "c")), "--out", str(disk / "diag"), "--jobs", "1"]) == 2
    (line,) = errors_of(capsys.readouterr().err)
    assert "could not be written (No space left on device)" in line, line
    failed = Path(line.split("twin: error: ")[1].split(": could not")[0])
    kept = Path(line.split(" are kept in ")[1])
    assert failed.parent == disk / "diag" and not failed.exists()
    assert (kept / "diagnosis.json").stat().st_size > 0 and not (kept / failed.name).exists()
    json.loads((kept / "diagnosis.json").read_text())  # what is kept is whole


def kept_after_a_failed_write(capsys, file: Path, how: str) -> Path:
    """The folder the one line on stderr says the files written before `file` are kept in, having
    checked that the line names `file`, the full disk and what became of `file` (`how`)."""
    (line,) = errors_of(capsys.readouterr().err)
    assert line.startswith(f"twin: error: {file}: could not be written (No space left on device), so {how}; "), line
    return Path(line.split(" are kept in ")[1])


def test_a_full_disk_under_paper_names_the_file_and_keeps_its_earlier_version(full_disk, monkeypatch, capsys):
    """`twin paper --out` on a disk that fills at its second partial result: exit 2, one line naming
    paper.partial.json and saying it holds its earlier version, and the folder kept beside DIR
    holding that version, whole, marked partial (before, the whole file was removed as cut short).
    Stand-ins: the validation, the as-built table and the experiments return small made-up results
    at once (the real ones take minutes); what `reproduce` writes and how the command handles the
    write that fails are the real code under test."""
    import scenarios.paper as paper
    from twin_cli.cli import main

    monkeypatch.setattr(paper, "prediction_validation", lambda: ({"stand_in": "validation"}, {}))
    monkeypatch.setattr(paper, "as_built_table", lambda: [])
    monkeypatch.setattr(
        paper, "EXPERIMENTS", dict.fromkeys(paper.EXPERIMENTS, lambda quick: {"stand_in": "x" * 10_000})
    )
    disk = full_disk(8192)
    assert main(["paper", "--quick", "--out", str(disk / "paper")]) == 2
    kept = kept_after_a_failed_write(
        capsys, disk / "paper" / "paper.partial.json", "it holds its earlier version, whole"
    )
    assert kept.parent == disk and kept.name.startswith("paper-saved-")
    earlier = json.loads((kept / "paper.partial.json").read_text())
    assert earlier == {
        "as_built": [],
        "prediction_error": {"stand_in": "validation"},
        "partial": True,
        "not_run": list(paper.EXPERIMENTS),
    }
    assert not any((disk / "paper").iterdir())  # nothing said to be written there


def stand_in_summary(strategy: str, mpa: float, seed: int) -> dict:
    """A cleaning run's summary with the fields the study's tables read, made up (8 discs cleaned)."""
    disc = {"cleaned": True, "peak_force_n": 20.0, "brushed_m": 0.1}
    overrides = {"control.strategy": strategy, "supply.pressure_mpa": mpa}
    return {
        "overrides": overrides,
        "seed": seed,
        "discs": [disc] * 8,
        "finished_s": 30.0,
        "joints": {"wrist_pitch": {"error_deg": 0.5}},
    }


def test_a_full_disk_under_study_names_the_picture_and_keeps_the_tables(full_disk, monkeypatch, capsys):
    """`twin study cleaning --out` on a disk that fills while its picture is written: exit 2, one
    line naming study.png as not there (Pillow removes what it could not finish), and study.json,
    .md and .csv kept whole beside DIR (before, the last of them written, study.csv, was blamed and
    removed as cut short). Stand-in: the runs (each a cleaning run of minutes) are made-up summaries returned at once;
    the study's tables, its picture and the command's handling of the failed write are real."""
    import scenarios.study as study
    from twin_cli.cli import main

    def runs(strategies, supplies, seeds, workers, finished, **_how):
        return [stand_in_summary(s, p, k) for s in strategies for p in supplies for k in range(seeds)]

    monkeypatch.setattr(study, "run_study", runs)
    disk = full_disk(32 * 1024)
    argv = ["study", "cleaning", "--out", str(disk / "study"), "--strategies", "sensorless", "--supplies", "0.5,0.8"]
    assert main([*argv, "--seeds", "1", "--workers", "1"]) == 2
    kept = kept_after_a_failed_write(capsys, disk / "study" / "study.png", "it is not there")
    assert sorted(p.name for p in kept.iterdir()) == ["study.csv", "study.json", "study.md"]
    assert json.loads((kept / "study.json").read_text()) == runs(["sensorless"], [0.5, 0.8], 1, 1, {})
    assert (kept / "study.csv").read_text().count("\n") == 3  # its header and a row per supply
    assert not any((disk / "study").iterdir())


def test_a_full_disk_under_gap_bench_names_the_case_and_keeps_the_cases_before_it(full_disk, monkeypatch, capsys):
    """`twin gap bench --out` on a disk that fills while its second case's campaign is written:
    exit 2, one line naming that case's folder (removed, unfinished) and DIR's bench.json of the
    first case kept whole beside DIR with its campaign. Stand-in: each case writes a made-up run
    file and returns a made-up "no gap" result at once (a real case generates and diagnoses a
    campaign, minutes); run_bench's writing and the command's handling of the failure are real."""
    import gap.bench as bench
    from twin_cli.cli import main

    def case_run(case, i, folder, *args):
        folder.mkdir(parents=True)
        with open(folder / "run.csv", "w") as f:
            f.write("time_s,angle_rad\n" + "0.000,0.0\n" * 1000)  # 11 kB
        return {"case": case.name, "kind": "none", "verdict": "no significant gap", "instrument": "", "diagnose_s": 0.0}

    monkeypatch.setattr(bench, "run_case", case_run)
    disk = full_disk(20 * 1024)
    assert main(["gap", "bench", "--out", str(disk / "bench"), "--quick", "--jobs", "1"]) == 2
    (line,) = errors_of(capsys.readouterr().err)
    first, second = bench.QUICK
    assert line.startswith(
        f"twin: error: {disk / 'bench' / 'campaigns' / second}: could not be written (No space left on device), "
        "so it is not there; "
    ), line
    kept = Path(line.split(" are kept in ")[1])
    assert [c["case"] for c in json.loads((kept / "bench.json").read_text())["cases"]] == [first]
    assert [p.name for p in (kept / "campaigns").iterdir()] == [first]
    assert not any((disk / "bench").iterdir())


# --- a stopped sweep keeps its finished runs ------------------------------------------------------
def sweep_stopped(cwd: Path, argv: list[str], bar: str, timeout: float) -> tuple[int, str, str, re.Match]:
    """`twin ARGV` in a child sent SIGTERM once its progress bar on stderr matches `bar`: its exit
    code, what it said before the signal and after, and the bar's match."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [sys.executable, "-m", "twin_cli.cli", *argv], env=env, cwd=cwd, stderr=subprocess.PIPE, text=True
    )
    seen = ""
    try:
        while not (match := re.search(bar, seen)):
            char = proc.stderr.read(1)
            assert char, seen
            seen += char
        proc.send_signal(signal.SIGTERM)
        rest = proc.communicate(timeout=timeout)[1]
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, seen, rest, match


def test_sigterm_to_a_sweep_keeps_the_runs_it_finished_as_a_partial_table(tmp_path):
    """`twin sweep --out` sent SIGTERM after its first runs: exit 143, and what it says is where
    they are: NAME.partial.json and NAME.partial.csv (a column partial) beside --out, holding every
    run that finished; no NAME.json, which would pass for the whole sweep. Before, nothing was kept
    and it said "the logs written so far are kept"."""
    import csv

    scenario = ROOT / "scenarios" / "wrist_closed_loop_60deg.toml"
    out = tmp_path / "s.json"
    argv = ["sweep", str(scenario), "--monte-carlo", "8", "--workers", "1", "--duration", "4", "--out", str(out)]
    code, seen, rest, _ = sweep_stopped(tmp_path, argv, r"\| [2-7]/8", 120)  # tqdm's bar: two runs or more finished
    said = [line for line in (seen + rest).replace("\r", "\n").splitlines() if line.startswith("twin:")]
    assert code == 143 and "Traceback" not in rest, rest
    partial, table = tmp_path / "s.partial.json", tmp_path / "s.partial.csv"
    kept = json.loads(partial.read_text())
    assert said[0] == (
        f"twin: stopped; the {len(kept)} of 8 runs that finished are in {partial} and, one row per run "
        f"(column partial), {table} (partial: the sweep did not end)"
    )
    assert said[1] == "twin: terminated (SIGTERM)" and len(said) == 2
    rows = list(csv.DictReader(table.open()))
    assert 2 <= len(kept) == len(rows) < 8 and all(r["partial"] == "True" for r in rows)
    assert [r["seed"] for r in rows] == [str(k["seed"]) for k in kept]
    assert not out.exists() and not (tmp_path / "s.csv").exists()


def test_sigterm_to_a_sweep_on_two_workers_keeps_the_runs_it_was_waiting_for(tmp_path):
    """`twin sweep --workers 2 --out` sent SIGTERM after its first runs: the runs in progress end
    (they are not cut) and their results are kept with the others: at least two more than had
    finished when it was stopped. Before, it waited for them and threw their results away."""
    # Signalled once the first run finished: the two in progress end and are kept; of the other five,
    # the pool has already handed at most three to its queue (max_workers + 1), so 3 to 6 are kept
    # (signalled later, the queued ones can make all 8). Runs of about a second each (60 s of the
    # arm's cleaning task), so that the runs left cannot all end between the bar's line and the signal.
    scenario = ROOT / "scenarios" / "insulator_cleaning.toml"
    argv = ["sweep", str(scenario), "--monte-carlo", "8", "--workers", "2", "--duration", "60"]
    argv += ["--out", str(tmp_path / "s.json")]
    code, _, rest, bar = sweep_stopped(tmp_path, argv, r"\| (1)/8", 180)
    assert code == 143 and "Traceback" not in rest, rest
    kept = json.loads((tmp_path / "s.partial.json").read_text())
    assert int(bar[1]) + 2 <= len(kept) < 8, (bar[1], len(kept))
    assert f"the {len(kept)} of 8 runs that finished are in {tmp_path / 's.partial.json'}" in rest


def stopped_after(finished: dict, done: dict):
    """Fill `finished` with `done`, then SIGTERM this process, as `timeout` or systemd would: the
    stop arrives while the command is at work (the handler raises at the next Python line)."""
    finished.update(done)
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(5)  # not reached: the signal stops it first
    raise AssertionError("SIGTERM did not stop the command")


def test_sigterm_to_study_keeps_the_runs_it_finished_as_a_partial_table(tmp_path, monkeypatch, capsys):
    """`twin study cleaning --out DIR` stopped by SIGTERM after two of its four runs: exit 143,
    DIR/study.partial.json and .csv hold those two (column partial), the stop says where, and no
    study.json stands for the whole study. Stand-in: the sweep of cleaning runs (minutes each)
    records two made-up finished runs and then the process sends itself SIGTERM; the command's
    handling of the stop and what it writes are real."""
    import csv

    import scenarios.study as study
    from twin_cli.cli import main

    done = {0: stand_in_summary("sensorless", 0.5, 0), 1: stand_in_summary("sensorless", 0.5, 1)}
    monkeypatch.setattr(study, "sweep", lambda scenario, grid, finished, **how: stopped_after(finished, done))
    out = tmp_path / "study"
    argv = ["study", "cleaning", "--out", str(out), "--strategies", "sensorless", "--supplies", "0.5,0.8"]
    assert main([*argv, "--seeds", "2", "--workers", "1"]) == 143
    err = capsys.readouterr().err
    assert f"the study's runs (study.partial.json, partial) finished so far are in {out}" in err, err
    assert "twin: terminated (SIGTERM)" in err
    assert [r["seed"] for r in json.loads((out / "study.partial.json").read_text())] == [0, 1]
    rows = list(csv.DictReader((out / "study.partial.csv").open()))
    assert [r["partial"] for r in rows] == ["True", "True"]
    assert not (out / "study.json").exists()


def test_sigterm_to_bench_prints_the_benchmarks_it_finished_marked_partial(monkeypatch, capsys):
    """`twin bench --json` stopped by SIGTERM during its second benchmark: exit 143, and stdout
    holds the first one's figures and `partial: stopped after twin`. Stand-in: the first
    benchmark returns made-up figures at once and the second sends this process SIGTERM (the real
    ones take minutes); run_all's bookkeeping and the command's handling of the stop are real."""
    import benchmarks.all as benches
    from twin_cli.cli import main

    monkeypatch.setattr(benches, "bench_twin", lambda **kw: {"realtime_factor": 3.0})
    monkeypatch.setattr(benches, "bench_plant", lambda **kw: stopped_after({}, {}))
    assert main(["bench", "--quick", "--json"]) == 143
    out, err = capsys.readouterr()
    assert json.loads(out) == {"twin": {"realtime_factor": 3.0}, "partial": "stopped after twin"}
    assert "twin: terminated (SIGTERM)" in err


def test_sigterm_to_paper_keeps_the_experiments_it_finished_marked_partial(tmp_path):
    """`twin paper` sent SIGTERM once its validation is done: exit 143, DIR/paper.partial.json holds
    the validation and names the experiments not run, and the stop says where. Before, the
    staging folder was removed and nothing was kept."""
    out = tmp_path / "paper"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    # not --quick: it shortens only the control experiments, and the quick ones can all end between
    # the validation's file appearing and the signal, leaving nothing to stop (exit 0)
    command = [sys.executable, "-m", "twin_cli.cli", "paper", "--out", str(out)]
    proc = subprocess.Popen(command, cwd=tmp_path, env=env, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while not list(tmp_path.glob(".paper.partial-*/paper.partial.json")) and proc.poll() is None:
            assert time.monotonic() < deadline, "the validation did not finish"
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)
        err = proc.communicate(timeout=120)[1].decode()
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 143 and "Traceback" not in err, err
    assert f"(paper.partial.json, partial) finished so far are in {out}" in err
    kept = json.loads((out / "paper.partial.json").read_text())
    assert kept["partial"] is True and kept["prediction_error"] and kept["not_run"][-1] == "error_vs_pressure"
    assert not (out / "paper.json").exists()


# --- long run files -----------------------------------------------------------------------------
def test_a_run_file_is_read_as_a_stream_and_refused_where_it_passes_600_s(tmp_path):
    """A 700 s run file with garbage after its 600th second: refused at the row that passes 600 s,
    the garbage never read (before, the whole file was parsed first: 39 s and 1.6 GB for 2
    million rows)."""
    from test_inputs import campaign

    from gap.campaign import GapError, load_campaign

    rows = [f"{k * 0.01:.2f},0,0,0,601325,0.0,," for k in range(70_000)] + ["this is not a row"]
    folder = campaign(tmp_path / "c", rows=rows)
    with pytest.raises(GapError, match=r"a\.csv:60003: time_s = 600\.01 is 600\.01 s after the first row; allowed"):
        load_campaign(folder)


def test_a_long_run_is_fitted_on_its_first_window_and_the_report_says_so(tmp_path):
    """Runs longer than FIT_WINDOW_S keep their first FIT_WINDOW_S seconds for the fit (each
    whole from its start, the state campaign.toml declares) and remember their length; the
    report's words say how many and how long (the cost: benchmarks/bench_long_runs.py)."""
    from test_inputs import campaign

    from gap.campaign import FIT_WINDOW_S, load_campaign
    from gap.report import window_line

    rows = [f"{k * 0.001:.3f},0,0,0,601325,{'0.0' if k % 20 == 0 else ''},," for k in range(20_001)]
    loaded = load_campaign(campaign(tmp_path / "c", rows=rows))
    for run in loaded.runs:
        assert run.recorded_s == 20.0 and run.time_s[-1] == FIT_WINDOW_S
        assert len(run.angle_rad) == len(run.time_s) == int(FIT_WINDOW_S * 1000) + 1
    line = window_line({r.name: r.recorded_s for r in loaded.runs})
    assert line.startswith(f"2 runs are longer than {FIT_WINDOW_S:g} s (up to 20 s recorded)")


def test_a_rerun_writer_that_never_finishes_is_reported_damaged_not_waited_for(tmp_path, monkeypatch):
    """rerun's flush can wait forever once its file writer failed (a full disk, intermittently):
    the recording's close gives it FLUSH_TIMEOUT_S, then names the file damaged, and takes rerun's
    exit-time shutdown off (it would wait for the same writer). The stuck flush is a stand-in: a
    flush that blocks on an event never set."""
    import threading

    import assets
    import twin.rerun_log as rl
    from twin.plant import Plant

    plant = Plant(assets.WRIST_RIG_XML)
    recorder = rl.RerunRecorder(tmp_path / "r.rrd", plant.model, plant.joints, {}, camera_fps=0)
    stuck = threading.Event()
    monkeypatch.setattr(recorder.rec, "flush", lambda **_: stuck.wait())
    monkeypatch.setattr(rl, "FLUSH_TIMEOUT_S", 0.5)
    unregistered = []
    monkeypatch.setattr(rl.rr, "unregister_shutdown", lambda: unregistered.append(True))
    with pytest.raises(rl.RerunLogError, match=r"r\.rrd: damaged: rerun's file writer did not finish within 0\.5 s"):
        recorder.close()
    assert unregistered
    stuck.set()  # the stand-in's thread ends (a real stuck writer's ends with the process)
