"""Build: generated code -> a standalone package in the content-addressed cache.

A build is keyed by a hash of the mechanism file and of everything that changes the generated
code (nemc's source and templates, the compiler flags, the Python ABI, cffi's version). It is
assembled in a private temporary folder and published by one atomic rename, so concurrent
builds of the same input both succeed and leave one good build, and a killed build leaves
only a temporary folder that the next build ignores.

The package holds the readable C source, compiled on its own with the flags below, a cffi
API-mode wrapper linked against it, the runtime (nemc/runtime.py, copied) and model.json.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import shutil
import subprocess
import sysconfig
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import cffi

from . import __version__
from .errors import BuildError

if TYPE_CHECKING:  # emit imports sympy; a cached load must not
    from .emit import Emitted

NEMC_DIR = Path(__file__).resolve().parent
TEMPLATE_DIR = NEMC_DIR.parent / "templates"
CC = os.environ.get("CC", "gcc")
CFLAGS = ["-O2", "-fPIC", "-Wall", "-Wextra", "-std=c99"]  # never -ffast-math: it changes answers
COMPLETE = "BUILD_OK"


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


def code_fingerprint() -> str:
    """A hash of nemc's own code and templates: any change to them changes every build key."""
    digest = hashlib.sha256()
    for path in sorted([*NEMC_DIR.glob("*.py"), *TEMPLATE_DIR.glob("*.tmpl")]):
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def build_key(source: Source, options: dict | None = None) -> str:
    identity = {
        "nemc": __version__,
        "code": code_fingerprint(),
        "source": source.sha256,
        "file": Path(source.path).name,
        "options": options or {},
        "abi": sysconfig.get_config_var("EXT_SUFFIX"),
        "cffi": cffi.__version__,
        "cc": CC,
        "cflags": CFLAGS,
    }
    return hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()[:24]


def cached_package(key: str) -> Path | None:
    path = cache_root() / key
    return path if (path / COMPLETE).is_file() else None


def compile_c(c_file: Path, wrapper_file: Path, out_file: Path) -> None:
    """Compile the model's C and the cffi wrapper in parallel, then link the extension."""
    include = sysconfig.get_paths()["include"]
    jobs = [
        [CC, *CFLAGS, "-c", str(c_file), "-o", str(c_file.with_suffix(".o"))],
        [CC, "-O2", "-fPIC", "-I", include, "-c", str(wrapper_file),
         "-o", str(wrapper_file.with_suffix(".o"))],
    ]
    running = [subprocess.Popen(j, stdout=subprocess.PIPE, stderr=subprocess.STDOUT) for j in jobs]
    for job, process in zip(jobs, running):
        output = process.communicate()[0].decode(errors="replace")
        if process.returncode:
            raise BuildError(f"the C compiler failed on {job[-3]}:\n$ {' '.join(job)}\n{output}")
    link = [CC, "-shared", str(c_file.with_suffix(".o")), str(wrapper_file.with_suffix(".o")),
            "-o", str(out_file), "-lm"]
    result = subprocess.run(link, capture_output=True, text=True)
    if result.returncode:
        raise BuildError(f"linking failed:\n$ {' '.join(link)}\n{result.stdout}{result.stderr}")


def write_package(code: Emitted, folder: Path) -> None:
    """Everything of the standalone package except the compiled extension."""
    folder.mkdir()
    (folder / "__init__.py").write_text(code.package_init)
    shutil.copyfile(NEMC_DIR / "runtime.py", folder / "_runtime.py")
    (folder / "model.json").write_text(json.dumps(code.metadata, indent=1) + "\n")
    (folder / f"{code.name}.c").write_text(code.c_source)


def build(code: Emitted, key: str) -> Path:
    """Build into the cache and publish atomically; returns the package folder."""
    root = cache_root()
    root.mkdir(parents=True, exist_ok=True)
    final = root / key
    scratch = Path(tempfile.mkdtemp(prefix=f".tmp-{code.name}-", dir=root))
    try:
        package = scratch / "package"
        write_package(code, package)
        ffi = cffi.FFI()
        ffi.cdef(code.cdef)
        ffi.set_source("_native", code.cdef)
        wrapper = scratch / "_native.c"
        with contextlib.redirect_stdout(io.StringIO()):  # cffi announces what it writes
            ffi.emit_c_code(str(wrapper))
        extension = package / ("_native" + sysconfig.get_config_var("EXT_SUFFIX"))
        compile_c(package / f"{code.name}.c", wrapper, extension)
        (package / f"{code.name}.o").unlink()
        (package / COMPLETE).write_text(key + "\n")
        publish(package, final)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return final


def publish(package: Path, final: Path) -> None:
    """Move a finished build into place, unless another process already published it."""
    if (final / COMPLETE).is_file():
        return
    if final.exists():  # an incomplete leftover: replace it
        shutil.rmtree(final, ignore_errors=True)
    try:
        os.rename(package, final)
    except OSError:
        if not (final / COMPLETE).is_file():
            raise


def export(package: Path, out_dir: Path, name: str) -> Path:
    """Copy a built package to OUT_DIR/<name>/, replacing any previous one in one rename."""
    out_dir.mkdir(parents=True, exist_ok=True)
    target = out_dir / name
    staging = Path(tempfile.mkdtemp(prefix=f".{name}-", dir=out_dir))
    try:
        shutil.copytree(package, staging / name, ignore=shutil.ignore_patterns("__pycache__"))
        old = staging / "old"
        if target.exists():
            os.rename(target, old)
        os.rename(staging / name, target)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return target
