"""The build cache under stress: concurrent builds, a build killed in the middle, corrupted
entries, a missing compiler, folders that cannot be written."""

from __future__ import annotations

import json
import os
import select
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from children import HANG

from nemc.build import builder as build
from nemc.build.builder import COMPLETE, build_key, cached_package, is_intact
from nemc.pipeline import compile_mechanism, generate_and_build, read_source
from nemc.tools.cli import main

ROOT = Path(__file__).resolve().parent.parent
COMPOUND = ROOT / "examples" / "compound_pendulum.yaml"
TINY = (ROOT / "tests" / "models" / "tiny.yaml").read_text()  # one rod on a pin


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("NEMC_CACHE", str(folder))
    return folder


def entries(cache: Path) -> list[Path]:
    """The builds in the cache (not the compiled drivers kept beside them)."""
    return sorted(p for p in cache.iterdir()
                  if not p.name.startswith(".") and p.name != build.DRIVERS_FOLDER)


def leftovers(cache: Path) -> list[Path]:
    return sorted(p for p in cache.iterdir() if p.name.startswith("."))


def environment(cache: Path, **extra: str) -> dict[str, str]:
    return {**os.environ, "NEMC_CACHE": str(cache), "PYTHONPATH": str(ROOT), **extra}


def start_compile(path: Path, env: dict[str, str]) -> subprocess.Popen:
    """A separate process: compile PATH, print the RHS at a fixed state and whether cached."""
    code = ("import sys, nemc.pipeline as p; c = p.compile_mechanism(sys.argv[1]); "
            "print(c.cached, repr(c.model.rhs(0.25, [0.3, -0.1]).tolist()))")
    return subprocess.Popen([sys.executable, "-c", code, str(path)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, start_new_session=True)


def run_cli(args: list[str], env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nemc.tools.cli", *args], capture_output=True,
                          text=True, env=env, timeout=120)


def test_concurrent_builds_of_the_same_and_of_different_models(cache: Path,
                                                               tmp_path: Path) -> None:
    tiny = tmp_path / "tiny.yaml"
    tiny.write_text(TINY)
    env = environment(cache)
    paths = [COMPOUND, tiny, COMPOUND, tiny]
    processes = [start_compile(path, env) for path in paths]
    results = [p.communicate(timeout=180) for p in processes]
    assert [p.returncode for p in processes] == [0] * 4, [err for _, err in results]
    values = [out.split(" ", 1)[1] for out, _ in results]
    assert values[0] == values[2] and values[1] == values[3] and values[0] != values[1]
    built = entries(cache)
    assert len(built) == 2 and all(is_intact(p, p.name) for p in built)
    assert leftovers(cache) == []
    again = start_compile(COMPOUND, env)
    out, err = again.communicate(timeout=120)
    assert out.split(" ", 1) == ["True", values[0]], err  # one good entry, reused


FAKE_CC = """\
#!/bin/sh
# a C compiler that, while the file SLOW exists, says so into the FIFO STARTED (a write that
# waits for the test to read it) and hangs before compiling
if [ -e "{slow}" ]; then echo started > "{started}"; sleep 1000; fi
exec gcc "$@"
"""


def fake_compiler(folder: Path) -> tuple[Path, Path, Path]:
    slow, started, script = folder / "SLOW", folder / "STARTED", folder / "slowcc"
    script.write_text(FAKE_CC.format(slow=slow, started=started))
    script.chmod(0o755)
    os.mkfifo(started)
    return script, slow, started


def compiler_started(started: Path, process: subprocess.Popen) -> bool:
    """Wait until the fake compiler says it started (True) or PROCESS ends first (False); the
    timeout only guards against a hang."""
    fifo = os.open(started, os.O_RDONLY | os.O_NONBLOCK)  # no writer yet: not readable
    try:
        assert process.stdout is not None  # at its end (EOF) once the process has ended
        ready, _, _ = select.select([fifo, process.stdout], [], [], HANG)
        assert ready, "hung: neither the compiler nor the build said anything"
        # (the build runs compilers in parallel: two may say it at once)
        return fifo in ready and os.read(fifo, 100).startswith(b"started\n")
    finally:
        os.close(fifo)


def stopped(process: subprocess.Popen) -> tuple[str, str]:
    """PROCESS and its compilers killed; its output (for a failing test's message)."""
    os.killpg(process.pid, signal.SIGKILL)
    return process.communicate(timeout=HANG)


def test_a_build_killed_during_gcc_leaves_the_cache_usable(cache: Path, tmp_path: Path) -> None:
    script, slow, started = fake_compiler(tmp_path)
    slow.touch()
    env = environment(cache, CC=str(script))
    victim = start_compile(COMPOUND, env)
    assert compiler_started(started, victim), stopped(victim)
    assert victim.poll() is None, stopped(victim)
    os.killpg(victim.pid, signal.SIGKILL)  # the process and its compilers, mid-build
    victim.communicate(timeout=HANG)
    assert entries(cache) == [] and len(leftovers(cache)) == 1  # only its scratch folder

    slow.unlink()
    survivor = start_compile(COMPOUND, env)
    out, err = survivor.communicate(timeout=180)
    assert survivor.returncode == 0 and out.startswith("False "), err
    built = entries(cache)
    assert len(built) == 1 and is_intact(built[0], built[0].name)

    day_old = time.time() - build.STALE_SCRATCH_S - 60
    for leftover in leftovers(cache):
        os.utime(leftover, (day_old, day_old))
    shutil.rmtree(built[0])
    survivor = start_compile(COMPOUND, env)
    assert survivor.communicate(timeout=180)[0].startswith("False ")
    assert leftovers(cache) == []  # the killed build's folder is gone once stale


def truncate_extension(entry: Path) -> None:
    extension = next(entry.glob("_native.*"))
    extension.write_bytes(extension.read_bytes()[:1000])


def rewrite(name: str, data: bytes) -> Callable[[Path], None]:
    return lambda entry: (entry / name).write_bytes(data)


def delete(pattern: str) -> Callable[[Path], None]:
    return lambda entry: next(entry.glob(pattern)).unlink()


def wrong_key(entry: Path) -> None:
    manifest = json.loads((entry / COMPLETE).read_text())
    (entry / COMPLETE).write_text(json.dumps({**manifest, "key": "0" * 24}))


def replace_by_file(entry: Path) -> None:
    shutil.rmtree(entry)
    entry.write_text("not a build")


CORRUPTIONS: dict[str, Callable[[Path], None]] = {
    "truncated extension": truncate_extension,
    "garbage extension": lambda entry: next(entry.glob("_native.*")).write_bytes(b"\0" * 64),
    "missing extension": delete("_native.*"),
    "garbage metadata": rewrite("model.json", b"{not json"),
    "edited metadata": lambda entry: (entry / "model.json").write_text(
        (entry / "model.json").read_text().replace('"W"', '"X"')),
    "missing metadata": delete("model.json"),
    "missing package init": delete("__init__.py"),
    "garbage manifest": rewrite(COMPLETE, b"\xff\xfe garbage"),
    "empty manifest": rewrite(COMPLETE, b"{}"),
    "old-style manifest": lambda entry: (entry / COMPLETE).write_text(entry.name + "\n"),
    "manifest of another key": wrong_key,
    "missing manifest": delete(COMPLETE),
    "a file instead of a folder": replace_by_file,
    "an empty folder": lambda entry: (shutil.rmtree(entry), entry.mkdir()),
}


@pytest.fixture(scope="module")
def pristine(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    """One good build of COMPOUND, never loaded (corrupting a loaded extension in place would
    crash this process; nemc itself never writes into a published entry)."""
    source = read_source(COMPOUND)
    key = build_key(source, {"jacobian": "auto"})  # the key compile_mechanism uses
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("NEMC_CACHE", str(tmp_path_factory.mktemp("pristine")))
        return key, generate_and_build(source, key, None, {})


@pytest.mark.parametrize("corrupt", CORRUPTIONS.values(), ids=CORRUPTIONS.keys())
def test_a_corrupted_entry_is_detected(cache: Path, pristine: tuple[str, Path],
                                       corrupt) -> None:
    key, good = pristine
    cache.mkdir()
    shutil.copytree(good, cache / key)
    assert cached_package(key) == cache / key
    corrupt(cache / key)
    assert cached_package(key) is None  # detected before anything is imported
    assert entries(cache) == [] and leftovers(cache) == []  # moved aside and removed


def test_a_broken_entry_is_replaced_by_the_next_build(cache: Path,
                                                      pristine: tuple[str, Path]) -> None:
    key, good = pristine
    cache.mkdir()
    shutil.copytree(good, cache / key)
    truncate_extension(cache / key)
    package = generate_and_build(read_source(COMPOUND), key, None, {})  # publish replaces it
    assert package == cache / key and is_intact(package, key) and cached_package(key) == package
    assert entries(cache) == [package] and leftovers(cache) == []


def test_an_entry_published_while_another_process_judged_it_stays(
        cache: Path, pristine: tuple[str, Path], monkeypatch: pytest.MonkeyPatch) -> None:
    """The race CI met: process A finds the entry broken (it was being replaced), process B
    publishes a good build, A moves the entry aside. A puts B's good build back; before, A
    deleted it and B's load found no extension."""
    key, good = pristine
    cache.mkdir()
    shutil.copytree(good, cache / key)
    looks = []
    real = build.is_intact

    def first_look_sees_the_old_broken_entry(path: Path, key: str) -> bool:
        looks.append(path)
        return len(looks) > 1 and real(path, key)

    monkeypatch.setattr(build, "is_intact", first_look_sees_the_old_broken_entry)
    assert cached_package(key) is None  # A rebuilds (harmless: its publish keeps B's)
    monkeypatch.setattr(build, "is_intact", real)
    assert entries(cache) == [cache / key] and is_intact(cache / key, key)
    assert leftovers(cache) == []


def test_a_truncated_extension_is_never_loaded(cache: Path) -> None:
    """In a fresh process (nothing imported yet): rebuilt, and the right numbers come out."""
    env = environment(cache)
    out_good, err = start_compile(COMPOUND, env).communicate(timeout=120)
    truncate_extension(entries(cache)[0])
    process = start_compile(COMPOUND, env)
    out, err = process.communicate(timeout=120)
    assert process.returncode == 0, err
    assert out.split(" ", 1) == ["False", out_good.split(" ", 1)[1]]


def test_missing_compiler_is_a_clear_build_error(cache: Path, tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))  # read when a build starts
    out = tmp_path / "out"
    assert main(["compile", str(COMPOUND), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "cannot run the C compiler" in err and "set the CC environment variable" in err
    assert not out.exists() and entries(cache) == [] and leftovers(cache) == []


def test_a_failing_compiler_is_a_build_error(cache: Path, tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    script = tmp_path / "badcc"
    script.write_text("#!/bin/sh\necho 'badcc: internal error' >&2\nexit 3\n")
    script.chmod(0o755)
    monkeypatch.setenv("CC", str(script))
    assert main(["compile", str(COMPOUND), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert "the C compiler failed on" in err and "badcc: internal error" in err
    assert entries(cache) == [] and leftovers(cache) == []


@pytest.mark.parametrize("env_change, message", [
    ({"CC": "/nonexistent/cc"}, "set the CC environment variable"),
    ({"PATH": ""}, "install gcc"),
])
def test_missing_compiler_from_the_command_line(cache: Path, tmp_path: Path, env_change,
                                                message: str) -> None:
    done = run_cli(["compile", str(COMPOUND), "-o", str(tmp_path / "out")],
                   environment(cache, **env_change))
    assert done.returncode == 1 and message in done.stderr
    assert "Traceback" not in done.stderr and done.stderr.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_unwritable_output_folder(cache: Path, tmp_path: Path, capsys) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    assert main(["compile", str(COMPOUND), "-o", str(blocker / "out")]) == 1
    err = capsys.readouterr().err
    assert f"cannot write the output folder {blocker / 'out'}" in err
    assert "choose a writable folder with -o/--output" in err
    assert blocker.read_text() == ""
    done = run_cli(["compile", str(COMPOUND), "-o", str(blocker)], environment(cache))
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "choose a writable folder" in done.stderr


def test_unwritable_cache_folder(tmp_path: Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    done = run_cli(["compile", str(COMPOUND)], environment(blocker / "cache"))
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "set NEMC_CACHE to a writable folder" in done.stderr


# ---- the native integrators' object, shared by the models of one size ----------------------

TWIN = TINY.replace("name: tiny", "name: twin").replace("m: 2, L: 0.5", "m: 3, L: 0.8")


def compiler_outputs(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The object files each later build's compiler jobs write, in one growing list."""
    written: list[str] = []
    run_jobs = build.run_jobs

    def recording(jobs, workers):
        written.extend(Path(job[-1]).name for job in jobs)
        return run_jobs(jobs, workers)

    monkeypatch.setattr(build, "run_jobs", recording)
    return written


def drivers_objects(cache: Path) -> list[Path]:
    return sorted((cache / build.DRIVERS_FOLDER).glob("*.o"))


def runs(path: Path) -> list:
    """Runs of every explicit native method, with t_eval and a step record."""
    import numpy as np

    model = compile_mechanism(path).model
    results = [model.simulate((0, 3), method=method, rtol=1e-9, atol=1e-12,
                              t_eval=np.linspace(0, 3, 7)) for method in ("nemc.DOP853",
                                                                          "nemc.Vern9")]
    results.append(model.simulate((0, 3), method="nemc.DOP853"))
    return [(r.status, r.nfev, r.t.tobytes(), r.y.tobytes()) for r in results]


def test_models_of_one_size_share_the_compiled_drivers(cache: Path, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """nemc_drivers.c names no model: the second model of one size links the first one's
    object, and runs as a build that compiled its own (another cache) to the bit."""
    tiny, twin = tmp_path / "tiny.yaml", tmp_path / "twin.yaml"
    tiny.write_text(TINY)
    twin.write_text(TWIN)
    written = compiler_outputs(monkeypatch)
    compile_mechanism(tiny)
    assert "nemc_drivers.o" in written and len(drivers_objects(cache)) == 1
    written.clear()
    shared = runs(twin)
    assert "twin.o" in written and "nemc_drivers.o" not in written
    assert len(drivers_objects(cache)) == 1
    monkeypatch.setenv("NEMC_CACHE", str(tmp_path / "another"))
    assert runs(twin) == shared and "nemc_drivers.o" in written
    monkeypatch.setenv("NEMC_CACHE", str(cache))
    compile_mechanism(ROOT / "examples" / "double_pendulum.yaml")  # 4 states: its own
    assert len(drivers_objects(cache)) == 2


@pytest.mark.parametrize("damage", ["flipped", "truncated", "link"])
def test_a_damaged_drivers_object_is_compiled_again(cache: Path, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch,
                                                    damage: str) -> None:
    """The object's sha256 is in its name: a changed, cut or replaced object is never linked;
    it is discarded and compiled again, and the build runs as before."""
    tiny, twin = tmp_path / "tiny.yaml", tmp_path / "twin.yaml"
    tiny.write_text(TINY)
    twin.write_text(TWIN)
    expected = runs(tiny)
    (kept,) = drivers_objects(cache)
    data = kept.read_bytes()
    if damage == "flipped":
        kept.write_bytes(data[:1000] + bytes([data[1000] ^ 1]) + data[1001:])
    elif damage == "truncated":
        kept.write_bytes(data[: len(data) // 2])
    else:
        kept.unlink()
        kept.symlink_to("/dev/zero")
    written = compiler_outputs(monkeypatch)
    compile_mechanism(twin)
    assert "nemc_drivers.o" in written
    (again,) = drivers_objects(cache)
    assert again.read_bytes() == data and not again.is_symlink()
    assert leftovers(cache / build.DRIVERS_FOLDER) == []
    for entry in entries(cache):
        shutil.rmtree(entry)
    assert runs(tiny) == expected


def test_the_drivers_functions_stay_inside_the_extension(cache: Path, tmp_path: Path) -> None:
    """What nemc_drivers.c and <name>.c share is hidden (NEMC_SHARED): the extension exports
    the model's own functions only, so two models in one process never share a symbol."""
    import ctypes

    tiny = tmp_path / "tiny.yaml"
    tiny.write_text(TINY)
    package = compile_mechanism(tiny).package
    (extension,) = package.glob("_native.*so")
    library = ctypes.CDLL(str(extension))
    assert hasattr(library, "tiny_integrate") and hasattr(library, "tiny_rhs")
    for shared in ("nemc_integrate", "nemc_integrate_many", "control_after_step",
                   "control_start", "record_step", "many_run", "start_run"):
        assert not hasattr(library, shared), shared


def test_the_code_fingerprint_follows_an_edited_file(tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """code_fingerprint hashes again only when a file's stat changed, and then it does."""
    module, template = tmp_path / "kind.py", tmp_path / "part.c.tmpl"
    module.write_text("x = 1\n")
    template.write_text("int f(void);\n")
    monkeypatch.setattr(build, "code_files",
                        lambda: (("kind.py", module), ("templates/part.c.tmpl", template)))
    first = build.code_fingerprint()
    assert build.code_fingerprint() == first
    stamp = module.stat().st_mtime_ns
    module.write_text("x = 2\n")  # the same size, another content, another time
    os.utime(module, ns=(stamp + 10**9, stamp + 10**9))
    second = build.code_fingerprint()
    assert second != first
    template.unlink()  # replaced by another file of the same text: hashed again, equal
    template.write_text("int f(void);\n")
    assert build.code_fingerprint() == second
    template.write_text("int g(void);\n")
    os.utime(template, ns=(stamp + 2 * 10**9, stamp + 2 * 10**9))
    assert build.code_fingerprint() not in (first, second)


def test_the_drivers_object_is_kept_per_machine(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """A cache shared by machines of two architectures keeps an object for each: the key
    names the machine, the compiler and its flags besides the text."""
    import platform

    drivers = tmp_path / "nemc_drivers.c"
    for name, text in (("nemc_drivers.c", "int f(void);\n"), ("nemc_drivers.h", ""),
                       ("nemc_run.h", "")):
        (tmp_path / name).write_text(text)
    here = build.drivers_key(drivers)
    assert build.drivers_key(drivers) == here
    monkeypatch.setattr(platform, "machine", lambda: "another-machine")
    elsewhere = build.drivers_key(drivers)
    monkeypatch.undo()
    monkeypatch.setenv("CC", "clang")
    assert len({here, elsewhere, build.drivers_key(drivers)}) == 3
    monkeypatch.delenv("CC")
    (tmp_path / "nemc_run.h").write_text("/* another version */\n")
    assert build.drivers_key(drivers) not in (here, elsewhere)
