"""Build: generated code -> a standalone package in the content-addressed cache.

A build is keyed by a hash of the mechanism file and of everything that changes the generated
code or its binary: the modules that derive, optimize and emit it and the templates (not the
runtime, the CLI or the reports: editing a plot label rebuilds nothing), the compiler command
and flags, the Python ABI, cffi's version. It is
assembled in a private temporary folder and published by one atomic rename, so concurrent
builds of the same input both succeed and leave one good build, and a killed build leaves
only a temporary folder that the next build ignores (and removes once it is a day old).

The last file written, BUILD_OK, is a manifest of every other file's sha256. A cache entry is
used only when every file matches it: a truncated, edited or partly deleted entry is moved
aside and rebuilt, never imported.

A cache entry holds the readable C source (a very long model's in several files, method
auto's look at the start in <name>_spectrum.c and the native integrators in nemc_drivers.c,
compiled in parallel), compiled on its own with the flags below, a cffi API-mode wrapper
linked against it, Model.rhs's small extension _rhs_call (templates/rhs_call.c.tmpl: the
right-hand side called through numpy's buffers), and model.json; `export` adds the runtime
(nemc/runtime.py and nemc/methods.py, as they are now) to make the standalone package.

nemc_drivers.c names no model: its text depends only on the number of states (and on whether
the build has the Jacobian, for Radau). Its object is kept in the cache's drivers/ folder under
a hash of that text, the headers it includes, the compiler, the flags and the machine, and
reused by every later build of the same text on the same kind of machine: a small model's
integrators are 90% of its compile time. The object's own sha256 is in its name, checked
before it is linked.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import hashlib
import json
import os
import shlex
import stat
import sys
import sysconfig
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import _cffi_backend  # the extension loads it anyway; cffi itself is imported to build only

from ..emit.resources import template_files
from ..errors import BuildError, describe
from ..vocabulary import COMPLETE, DRIVERS, RHS_CALL, RUN_HEADER, RUNTIME_PACKAGE
from ..vocabulary import NEMC_VERSION as __version__

if TYPE_CHECKING:  # emit imports sympy; a cached load must not (nor subprocess, cffi, ...)
    import subprocess
    from importlib.abc import Traversable

    from ..emit.emitted import Emitted

NEMC_DIR = Path(__file__).resolve().parent.parent
# nemc's folders and modules that do not change what a build contains: they run, present or
# measure it. Every other module under nemc/ (and every template) is part of the build key.
NOT_IN_BUILD_KEY = frozenset({"runtime", "tools", "errors.py"})
CFLAGS = ["-O2", "-fPIC", "-Wall", "-Wextra", "-std=c99"]  # never -ffast-math: it changes answers
# A long model's unit files (straight-line parts of its programs, emit.parts.UNIT_STEPS), and every
# model's <name>_spectrum.c (auto's look at the start: 0.07 s of gcc, 0.11 at -O2), at -O1: gcc
# took 35% less time on a 100-body chain with its Jacobian (8.0 -> 5.2 s) for a right-hand side
# about 2% slower (4.77 -> 4.86 us a state) and the same Jacobian. The arithmetic is the same
# (no contraction under -std=c99): the results are bit-identical. docs/decisions.md.
UNIT_CFLAGS = ["-O1", *CFLAGS[1:]]
# cffi's wrapper (_native.c, about 100 kB of argument conversions for every declared function)
# unoptimized: gcc takes 0.14 s on it instead of 0.37-0.43 at -O2, the largest job of a small
# model's build, and its calls cost the same (model.rhs through cffi 1.15-1.18 us against
# 1.18, simulate over [0, 0] 10.1-10.3 us either way: the time is in _cffi_backend's
# conversions). docs/decisions.md, "A small model's build".
WRAPPER_CFLAGS = ["-O0", "-fPIC"]
# The native integrators (nemc_drivers.c), compiled once per text and kept (drivers_object),
# at -O3: the same bits, for loops over the states that gcc now unrolls and vectorizes (rtol
# 1e-9: nemc.DOP853 and nemc.Vern9 1.16x faster on a 3-link chain, 1.05-1.07x on 4 links,
# 1.03-1.05x on 8; nemc.Radau 1.05-1.17x), for 0.05-0.16 s more of gcc (0.2-0.5 s with Radau)
# once per size. docs/decisions.md, "A small model's build".
DRIVERS_CFLAGS = ["-O3", *CFLAGS[1:]]
# The cffi wrapper uses only CPython's stable ABI (3.10 on): the extension, named .abi3.so,
# loads in any later CPython too. A free-threaded CPython has no stable ABI: its own suffix.
LIMITED_API = "0x030A0000"
# Model.rhs's own extension (RHS_CALL), apart from _native: the buffer protocol it reads numpy's
# arrays with is in the stable ABI from 3.11 on.
CALL_LIMITED_API = "0x030B0000"
STALE_SCRATCH_S = 24 * 3600  # a temporary build folder this old was left by a killed build
# Names of nemc's own temporary entries in the cache folder: only these are ever cleaned up,
# so a NEMC_CACHE shared with other programs (even /tmp) loses none of their files.
SCRATCH_PREFIX = ".nemc-tmp-"
BROKEN_PREFIX = ".nemc-broken-"
MAX_MANIFEST_BYTES = 1_000_000
# The cache's folder of compiled nemc_drivers.c, one object per text (drivers_object)
DRIVERS_FOLDER = "drivers"
# Compiler jobs at once, at most (a long model's unit files: up to about 150 MB of memory each)
MAX_COMPILER_JOBS = 8


@dataclass(frozen=True)
class Source:
    """A mechanism file as read: its path as given, bytes and content hash."""

    path: str
    data: bytes

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.data).hexdigest()


def cache_root() -> Path:
    configured = os.environ.get("NEMC_CACHE")
    if configured:
        return Path(configured)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "nemc"


def build_modules() -> list[Path]:
    """nemc's modules whose content changes what a build contains (all but NOT_IN_BUILD_KEY)."""
    return sorted(path for path in NEMC_DIR.rglob("*.py")
                  if path.relative_to(NEMC_DIR).parts[0] not in NOT_IN_BUILD_KEY)


@functools.cache
def code_files() -> tuple[tuple[str, Traversable], ...]:
    """The files of code_fingerprint, each with the name it is hashed under: build_modules and
    the templates, listed once per process (a new module or template is used only by code that
    a new process imports)."""
    return (*((path.relative_to(NEMC_DIR).as_posix(), path) for path in build_modules()),
            *((f"templates/{template.name}", template) for template in template_files()))


def code_fingerprint() -> str:
    """A hash of the code that makes builds (build_modules and the templates): any change to
    it changes every build key. Read and hashed again only when a file's stat changed
    (file_stamp): every compile asks, cached ones too, and the stat calls take 0.1 ms where
    reading and hashing take 2.4 (a cached nemc.compile took 3.1 ms in all)."""
    files = code_files()
    return hashed_files(files, tuple(file_stamp(path) for _, path in files))


def file_stamp(path: Traversable) -> object:
    """A file's inode, size and modification and change times (an editor that replaces the
    file gives a new inode); a fresh object where it has none to give (a template inside an
    archive), so that it is hashed every time."""
    if not isinstance(path, Path):
        return object()
    info = path.stat()
    return info.st_ino, info.st_size, info.st_mtime_ns, info.st_ctime_ns


@functools.lru_cache(maxsize=1)
def hashed_files(files: tuple[tuple[str, Traversable], ...], stamps: tuple[object, ...]) -> str:
    """The sha256 of FILES's names and contents (STAMPS: their stat, the cache's key)."""
    digest = hashlib.sha256()
    for name, path in files:
        digest.update(name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def build_key(source: Source, options: dict | None = None) -> str:
    identity = {
        "nemc": __version__,
        "code": code_fingerprint(),
        "source": source.sha256,
        "file": Path(source.path).name,
        "options": options or {},
        "abi": sysconfig.get_config_var("EXT_SUFFIX"),
        "cffi": _cffi_backend.__version__,  # cffi.__version__: cffi refuses another backend
        "cc": compiler(),
        "cflags": CFLAGS,
        "unit_cflags": UNIT_CFLAGS,
        "drivers_cflags": DRIVERS_CFLAGS,
        "fma": fma_available(),
    }
    return hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()[:24]


def file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def write_manifest(package: Path, key: str) -> None:
    """Record every file's hash in BUILD_OK, written last: its presence marks a whole build."""
    files = {p.name: file_digest(p) for p in sorted(package.iterdir()) if p.is_file()}
    (package / COMPLETE).write_text(json.dumps({"key": key, "files": files}, indent=1) + "\n")


def is_intact(package: Path, key: str) -> bool:
    """Whether PACKAGE is a complete build of KEY whose files all match its manifest: a real
    folder of regular files (a symbolic link, a FIFO or /dev/zero in their place is broken,
    never read)."""
    try:
        if not stat.S_ISDIR(os.lstat(package).st_mode) or not is_regular(package / COMPLETE,
                                                                          MAX_MANIFEST_BYTES):
            return False
        manifest = json.loads((package / COMPLETE).read_text())
        files = manifest["files"]
        return manifest["key"] == key and bool(files) and all(
            is_plain_name(name) and is_regular(package / name)
            and file_digest(package / name) == digest for name, digest in files.items())
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return False


def is_regular(path: Path, max_bytes: int | None = None) -> bool:
    info = os.lstat(path)
    return stat.S_ISREG(info.st_mode) and (max_bytes is None or info.st_size <= max_bytes)


def is_plain_name(name: object) -> bool:
    """A file name inside the entry (a manifest naming ../x would read outside it)."""
    return isinstance(name, str) and name not in ("", ".", "..") and "/" not in name \
        and "\0" not in name


def discard(path: Path, key: str | None = None) -> None:
    """Remove a broken cache entry: first renamed aside (atomic), so no process can load it.

    With KEY, what was moved aside is checked again: another process may have published a good
    build of KEY in its place after this one found the entry broken. That build goes back
    (unless yet another one took the place meanwhile), so no process loses the entry it just
    published."""
    aside = path.with_name(f"{BROKEN_PREFIX}{path.name}-{os.getpid()}-{time.time_ns()}")
    try:
        os.rename(path, aside)
    except OSError:  # gone already, or another process moved it first
        return
    if key is not None and is_intact(aside, key):
        with contextlib.suppress(OSError):  # the place was taken again: ours is a spare
            os.rename(aside, path)
            return
    remove(aside)


def remove(path: Path) -> None:
    import shutil

    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(OSError):
            path.unlink()


def cached_package(key: str) -> Path | None:
    """The intact cache entry of KEY, or None; a broken entry is discarded (and so rebuilt)."""
    path = cache_root() / key
    if not os.path.lexists(path):  # checked first: an entry published after this is not broken
        return None
    if is_intact(path, key):
        return path
    discard(path, key)  # anything at all, a dangling symbolic link included
    return None


def compiler() -> list[str]:
    """The C compiler command: $CC as the environment gives it now (a command line), or gcc;
    a $CC the shell's rules cannot split (an unclosed quote) is a BuildError naming it."""
    try:
        return shlex.split(os.environ.get("CC", "")) or ["gcc"]
    except ValueError as error:
        raise BuildError(f"CC={os.environ['CC']!r}: not a command line ({error})") from None


# Lanes per batch of nemc.Taylor's ensembles (templates/batch.c.tmpl): one vector register of
# doubles. Where the building CPU has AVX-512, 8 lanes in one zmm register are 1.2x faster than
# 4 in a ymm register on the book's pendulum (docs/decisions.md, "8 lanes where the CPU has
# AVX-512"); elsewhere 4 (AVX2; 8 lanes compiled for AVX2 are 6x slower, split through the stack).
WIDE_LANES, NARROW_LANES = 8, 4


def cpu_flags(cpuinfo: Path = Path("/proc/cpuinfo")) -> frozenset[str]:
    """The instruction-set features the CPU reports (Linux's CPUINFO "flags"; none elsewhere)."""
    try:
        with cpuinfo.open() as file:
            flags = next((line for line in file if line.startswith("flags")), "")
    except OSError:
        return frozenset()
    return frozenset(flags.partition(":")[2].split())


def lane_count(cpuinfo: Path = Path("/proc/cpuinfo")) -> int:
    """The lanes per batch for a lanes build on this machine: WIDE_LANES where the CPU reports
    AVX-512F (Linux's CPUINFO), else NARROW_LANES. The build runs where it was made; a build
    loaded on a CPU without its vector unit runs its ensembles one run after the other, with the
    same results."""
    return WIDE_LANES if "avx512f" in cpu_flags(cpuinfo) else NARROW_LANES


@functools.cache
def this_cpu_flags() -> frozenset[str]:
    """cpu_flags of the machine this process runs on, read once (every build key asks)."""
    return cpu_flags()


def fma_available(cpuinfo: Path | None = None, machine: str | None = None) -> bool:
    """Whether builds made here fuse nemc.Taylor's multiply-adds (templates/taylor.c.tmpl's
    TAYLOR_MULADD): on x86-64 where the CPU reports FMA (Linux's CPUINFO), and on AArch64,
    whose baseline has it. Part of the build key: a cache shared with a CPU without FMA keeps
    that CPU's builds apart, and a build copied to one refuses nemc.Taylor (taylor_ready)."""
    machine = machine or os.uname().machine
    if machine in ("aarch64", "arm64"):
        return True
    flags = this_cpu_flags() if cpuinfo is None else cpu_flags(cpuinfo)
    return machine in ("x86_64", "AMD64") and "fma" in flags


def start(command: list[str]) -> subprocess.Popen:
    """Start a compiler job; a compiler that cannot be run is a BuildError saying what to do."""
    import subprocess

    try:
        return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    except OSError as error:
        raise BuildError(f"cannot run the C compiler {command[0]!r} ({describe(error)}): install "
                         "gcc, or set the CC environment variable to a working C compiler "
                         f"(CC is {os.environ.get('CC', '')!r})") from None


def compile_c(c_file: Path, wrapper_file: Path, out_file: Path, units: Sequence[Path],
              rhs_call: Path, drivers: Path) -> None:
    """Compile the model's C (its unit files too), the native integrators (DRIVERS's C: unless
    the cache has its object), the cffi wrapper and Model.rhs's extension (RHS_CALL's C, linked
    apart into _rhs_call), in parallel on the available cores, then link the extensions."""
    include = sysconfig.get_paths()["include"]
    cc = compiler()
    key = drivers_key(drivers)
    cached_drivers = drivers_object(drivers, key)
    # the largest first, so that the last to finish is a short one
    sources = sorted([c_file, *units, *([] if cached_drivers else [drivers])],
                     key=lambda c: c.stat().st_size, reverse=True)
    flags = {c_file: CFLAGS, drivers: DRIVERS_CFLAGS}
    jobs = [[*cc, *flags.get(c, UNIT_CFLAGS), "-c", str(c), "-o", str(c.with_suffix(".o"))]
            for c in sources]
    jobs.insert(1, [*cc, *WRAPPER_CFLAGS, *limited_api_flags(), "-I", include, "-c",
                    str(wrapper_file), "-o", str(wrapper_file.with_suffix(".o"))])
    jobs.append([*cc, *CFLAGS, *package_c_flags(rhs_call), "-c", str(rhs_call), "-o",
                 str(rhs_call.with_suffix(".o"))])
    run_jobs(jobs, min(max(usable_cores(), 2), MAX_COMPILER_JOBS))
    link(cc, [*(c.with_suffix(".o") for c in [c_file, *units, drivers]),
              wrapper_file.with_suffix(".o")], out_file)
    link(cc, [rhs_call.with_suffix(".o")], out_file.with_name(RHS_CALL + call_suffix()))
    if not cached_drivers:
        keep_drivers_object(drivers, key)


def drivers_key(drivers: Path) -> str:
    """What the object of DRIVERS (nemc_drivers.c) depends on: its text, the text of the
    headers it includes (beside it), the compiler command and the flags, and the machine it is
    for (a cache shared by the workers of a cluster may serve x86-64 and AArch64 alike)."""
    import platform

    identity = {"cc": compiler(), "cflags": DRIVERS_CFLAGS, "platform": sys.platform,
                "machine": platform.machine()}
    digest = hashlib.sha256(json.dumps(identity, sort_keys=True).encode())
    for name in (drivers.name, f"{DRIVERS}.h", f"{RUN_HEADER}.h"):
        digest.update(name.encode() + b"\0" + drivers.with_name(name).read_bytes() + b"\0")
    return digest.hexdigest()[:32]


def drivers_object(drivers: Path, key: str) -> bool:
    """Put the cached object of DRIVERS (its drivers_key KEY) beside it (nemc_drivers.o), if
    the cache has an intact one (its content's sha256 is in its name); returns whether it did.
    A broken one is discarded."""
    for entry in sorted((cache_root() / DRIVERS_FOLDER).glob(f"{key}-*.o")):
        try:
            data = entry.read_bytes() if is_regular(entry) else b""
        except OSError:
            continue
        if hashlib.sha256(data).hexdigest()[:16] == entry.stem.partition("-")[2]:
            drivers.with_suffix(".o").write_bytes(data)
            return True
        discard(entry)
    return False


def keep_drivers_object(drivers: Path, key: str) -> None:
    """Move DRIVERS's object (its drivers_key KEY), just compiled and linked, into the cache by
    one atomic rename (a copy another build kept meanwhile is as good). A cache that refuses it
    costs only the next build's compile."""
    compiled = drivers.with_suffix(".o")
    name = f"{key}-{file_digest(compiled)[:16]}.o"
    with contextlib.suppress(OSError):
        folder = cache_root() / DRIVERS_FOLDER
        folder.mkdir(exist_ok=True)
        os.replace(compiled, folder / name)


def link(cc: list[str], objects: Sequence[Path], out_file: Path) -> None:
    """Link OBJECTS into the shared library OUT_FILE."""
    command = [*cc, "-shared", *map(str, objects), "-o", str(out_file), "-lm"]
    process = start(command)
    output = process.communicate()[0].decode(errors="replace")
    if process.returncode:
        raise BuildError(f"linking failed:\n$ {' '.join(command)}\n{output}")


def usable_cores() -> int:
    """The cores this process may run on (its affinity mask, else the machine's count)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def run_jobs(jobs: Sequence[list[str]], workers: int) -> None:
    """Run the compiler jobs in order, at most WORKERS at once, each started as soon as a
    worker is free (one that finished early no longer waits for an older, longer job); the
    first failure is a BuildError (no job starts after it; those running are waited for)."""
    from concurrent.futures import ThreadPoolExecutor

    failures: list[BuildError] = []

    def run(job: list[str]) -> None:
        if failures:
            return
        process = start(job)
        output = process.communicate()[0].decode(errors="replace")
        if process.returncode:
            failures.append(BuildError(f"the C compiler failed on {job[-3]}:\n"
                                       f"$ {' '.join(job)}\n{output}"))

    with ThreadPoolExecutor(workers) as pool:
        for future in [pool.submit(run, job) for job in jobs]:
            future.result()
    if failures:
        raise failures[0]


def stable_abi() -> bool:
    return not sysconfig.get_config_var("Py_GIL_DISABLED")


def limited_api_flags() -> list[str]:
    return [f"-DPy_LIMITED_API={LIMITED_API}"] if stable_abi() else []


def call_stable_abi() -> bool:
    """Whether Model.rhs's extension is built for the stable ABI: it needs the buffer
    protocol, part of the stable ABI from CPython 3.11 on."""
    return stable_abi() and sys.version_info >= (3, 11)


def call_api_flags() -> list[str]:
    return [f"-DPy_LIMITED_API={CALL_LIMITED_API}"] if call_stable_abi() else []


def package_c_flags(c_file: Path) -> list[str]:
    """What a C file of a package needs besides the compiler flags: Python's headers and its
    stable ABI for _rhs_call.c (a Python extension), nothing for the model's own C."""
    if c_file.name == f"{RHS_CALL}.c":
        return [*call_api_flags(), "-I", sysconfig.get_paths()["include"]]
    return []


def call_suffix() -> str:
    """.abi3.so (any CPython >= 3.11; in 3.10 its import fails, and Model.rhs goes through
    cffi), or this interpreter's own suffix (3.10, a free-threaded CPython)."""
    return ".abi3.so" if call_stable_abi() and os.name == "posix" else sysconfig.get_config_var(
        "EXT_SUFFIX")


def extension_suffix() -> str:
    """.abi3.so (the stable ABI: any CPython >= 3.10), or this interpreter's own suffix."""
    return ".abi3.so" if stable_abi() and os.name == "posix" else sysconfig.get_config_var(
        "EXT_SUFFIX")


def write_package(code: Emitted, folder: Path) -> None:
    """Everything of the standalone package except the compiled extension."""
    folder.mkdir()
    (folder / "__init__.py").write_text(code.package_init)
    (folder / "model.json").write_text(json.dumps(code.metadata, indent=1) + "\n")
    (folder / f"{code.name}.c").write_text(code.c_source)
    for path, text in side_sources(code, folder):
        path.write_text(text)
    (folder / f"{code.name}.h").write_text(code.header)
    for name, text in code.shared_headers:
        (folder / name).write_text(text)
    (folder / f"{DRIVERS}.c").write_text(code.drivers)
    (folder / f"{RHS_CALL}.c").write_text(code.rhs_call)


def side_sources(code: Emitted, folder: Path) -> list[tuple[Path, str]]:
    """The model's C files besides <name>.c, and their text, compiled in parallel with it:
    its unit files (emit.parts.Units: <name>_unit<k>.c, k = 1, 2, ...) and <name>_spectrum.c."""
    return [*((folder / f"{code.name}_unit{k}.c", text)
              for k, text in enumerate(code.units, start=1)),
            (folder / f"{code.name}_spectrum.c", code.spectrum)]


def scratch_folder(root: Path, name: str) -> Path:
    """A private temporary folder in the cache; unusable cache folders are a BuildError."""
    import tempfile

    try:
        root.mkdir(parents=True, exist_ok=True)
        remove_stale_scratch(root)
        return Path(tempfile.mkdtemp(prefix=f"{SCRATCH_PREFIX}{name}-", dir=root))
    except OSError as error:
        raise BuildError(f"cannot write to the nemc cache folder {root} ({describe(error)}): "
                         "set NEMC_CACHE to a writable folder") from None


def remove_stale_scratch(root: Path) -> None:
    """Delete what killed builds left long ago (a live build is never that old)."""
    cutoff = time.time() - STALE_SCRATCH_S
    for leftover in [*root.glob(f"{SCRATCH_PREFIX}*"), *root.glob(f"{BROKEN_PREFIX}*")]:
        with contextlib.suppress(OSError):
            if leftover.lstat().st_mtime < cutoff:
                remove(leftover)


def build(code: Emitted, key: str) -> Path:
    """Build into the cache and publish atomically; returns the package folder."""
    import io
    import shutil

    import cffi

    root = cache_root()
    final = root / key
    scratch = scratch_folder(root, code.name)
    try:
        package = scratch / "package"
        write_package(code, package)
        ffi = cffi.FFI()
        ffi.cdef(code.cdef)
        ffi.set_source("_native", code.cdef)
        wrapper = scratch / "_native.c"
        with contextlib.redirect_stdout(io.StringIO()):  # cffi announces what it writes
            ffi.emit_c_code(str(wrapper))
        extension = package / ("_native" + extension_suffix())
        units = [path for path, _ in side_sources(code, package)]
        rhs_call, drivers = package / f"{RHS_CALL}.c", package / f"{DRIVERS}.c"
        compile_c(package / f"{code.name}.c", wrapper, extension, units, rhs_call, drivers)
        for c_file in [package / f"{code.name}.c", *units, rhs_call, drivers]:
            c_file.with_suffix(".o").unlink(missing_ok=True)  # the drivers' kept in the cache
        write_manifest(package, key)
        publish(package, final, key)
    except OSError as error:  # e.g. the disk filled up while writing the package
        raise BuildError(f"cannot write the build in the nemc cache folder {root} "
                         f"({describe(error)}): {cache_advice(error)}") from None
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return final


def cache_advice(error: OSError) -> str:
    """What to do about a failed write in the cache, from its cause."""
    if error.errno in (errno.ENOSPC, errno.EDQUOT):
        return "free some space, or set NEMC_CACHE to a folder on another disk"
    return "set NEMC_CACHE to a writable folder (or remove the entry named above)"


def publish(package: Path, final: Path, key: str) -> None:
    """Move a finished build into place, unless another process already published one."""
    if is_intact(final, key):
        return
    if os.path.lexists(final):  # a broken leftover of any kind: move it aside first
        discard(final, key)
    try:
        os.rename(package, final)
    except OSError:  # another process published between our check and our rename
        if not is_intact(final, key):
            raise


def export(package: Path, out_dir: Path, name: str) -> Path:
    """Copy a built package to OUT_DIR/<name>/, replacing any previous one in one rename."""
    try:
        return copy_out(package, out_dir, name)
    except OSError as error:
        raise BuildError(f"cannot write the output folder {out_dir} ({describe(error)}): "
                         "choose a writable folder with -o/--output") from None


def copy_out(package: Path, out_dir: Path, name: str) -> Path:
    """OUT_DIR/<name>/, replaced only if nemc wrote it (nemc/export.py)."""
    from .export import export_package

    return export_package(package, out_dir, name, key=package.name, extras=runtime_files())


def runtime_files() -> dict[str, Path]:
    """nemc's runtime as an exported package holds it (its path there -> the file): the
    vocabulary and the runtime package under RUNTIME_PACKAGE, with their relative imports."""
    files = {f"{RUNTIME_PACKAGE}/vocabulary.py": NEMC_DIR / "vocabulary.py"}
    files.update({f"{RUNTIME_PACKAGE}/runtime/{path.name}": path
                  for path in sorted((NEMC_DIR / "runtime").glob("*.py"))})
    return files
