"""An FMU file read with limits (a zip someone else made; what is refused: docs/fmu.md): its
members checked before anything is read, sizes counted again while extracting, its
``modelDescription.xml`` parsed by fmpy and, in a worker only, the zip extracted into a
private folder of the process; the binary is loaded by :mod:`.binary`.
"""

from __future__ import annotations

import atexit
import dataclasses
import functools
import io
import os
import shutil
import stat
import tempfile
import zipfile
from pathlib import Path, PurePosixPath
from typing import Any

from vpid_bench import ConfigError

KEY = "problem.fmu"
MAX_MEMBERS = 10_000
MAX_MEMBER_BYTES = 512 * 1024**2
MAX_TOTAL_BYTES = 1024**3
MAX_DESCRIPTION_BYTES = 64 * 1024**2
MAX_NAME = 1024
CHUNK = 1024**2


def fail(path: Any, allowed: str) -> ConfigError:
    """The one-line error of ``problem.fmu``."""
    return ConfigError(KEY, str(path), allowed)


@dataclasses.dataclass(frozen=True)
class FmuFile:
    """An FMU's description and, per interface (``cs``, ``me``), this platform's binary."""

    path: str
    description: Any
    version: str
    binaries: dict[str, str]
    token: str

    @property
    def major(self) -> int:
        return int(self.version[0])


def _bad_name(name: str) -> str | None:
    """Why a member name is refused, or ``None``."""
    if len(name) > MAX_NAME:
        return f"more than {MAX_NAME} characters"
    if any(ord(ch) < 32 or ch == "\x7f" for ch in name):
        return "a control character"
    if "\\" in name:
        return "a backslash"
    if name.startswith("/") or (len(name) > 1 and name[1] == ":"):
        return "an absolute path"
    parts = PurePosixPath(name).parts
    if any(p in ("..", "") for p in parts) or ".." in name.split("/"):
        return "a '..' part (a path outside the FMU's folder)"
    return None


def _members(path: Path, z: zipfile.ZipFile) -> list[zipfile.ZipInfo]:
    infos = z.infolist()
    if len(infos) > MAX_MEMBERS:
        raise fail(path, f"an FMU of at most {MAX_MEMBERS} members (this one: {len(infos)})")
    total = 0
    for info in infos:
        why = _bad_name(info.filename)
        if why is not None:
            raise fail(path, f"an FMU whose member names stay inside its folder; a member "
                       f"name has {why}")
        if stat.S_ISLNK(info.external_attr >> 16):
            raise fail(path, f"an FMU without symbolic links; member {info.filename} is one")
        if info.file_size > MAX_MEMBER_BYTES:
            raise fail(path, f"members of at most {MAX_MEMBER_BYTES // 1024**2} MiB; "
                       f"{info.filename} has {info.file_size / 1024**2:.0f} MiB")
        total += info.file_size
    if total > MAX_TOTAL_BYTES:
        raise fail(path, f"an FMU of at most {MAX_TOTAL_BYTES // 1024**2} MiB unpacked "
                   f"(this one: {total / 1024**2:.0f} MiB)")
    return infos


def _read_limited(z: zipfile.ZipFile, info: zipfile.ZipInfo, limit: int, path: Path) -> bytes:
    out = io.BytesIO()
    with z.open(info) as fh:
        while chunk := fh.read(CHUNK):
            out.write(chunk)
            if out.tell() > limit:
                raise fail(path, f"member {info.filename} of at most {limit // 1024**2} MiB "
                           "(it unpacks to more than its declared size)")
    return out.getvalue()


def _description(path: Path, z: zipfile.ZipFile) -> Any:
    try:
        info = z.getinfo("modelDescription.xml")
    except KeyError:
        raise fail(path, "an FMU with a modelDescription.xml at its top level") from None
    xml = _read_limited(z, info, MAX_DESCRIPTION_BYTES, path)
    if b"<!DOCTYPE" in xml or b"<!ENTITY" in xml:
        raise fail(path, "a modelDescription.xml without a document type or entities")
    from fmpy import read_model_description

    try:
        with tempfile.TemporaryDirectory(prefix="vpid-fmu-md-") as tmp:
            target = Path(tmp) / "modelDescription.xml"
            target.write_bytes(xml)
            return read_model_description(str(target), validate=True)
    except Exception as exc:  # fmpy raises its own and lxml's errors
        text = " ".join(str(exc).split())[:200]
        raise fail(path, f"a valid modelDescription.xml (fmpy: {text})") from None


@functools.lru_cache(maxsize=16)
def _inspect(path: str, size: int, mtime_ns: int) -> FmuFile:
    p = Path(path)
    try:
        z = zipfile.ZipFile(p)
    except (zipfile.BadZipFile, OSError) as exc:
        raise fail(p, f"an FMU file (a zip; {exc})") from None
    with z:
        names = {i.filename for i in _members(p, z)}
        md = _description(p, z)
    version = str(md.fmiVersion)
    if version not in ("2.0",) and not version.startswith("3."):
        raise fail(p, f"an FMU of FMI 2.0 or 3.0 (this one states fmiVersion {version[:20]})")
    identifiers = {}
    if md.coSimulation is not None:
        identifiers["cs"] = md.coSimulation.modelIdentifier
    if md.modelExchange is not None:
        identifiers["me"] = md.modelExchange.modelIdentifier
    if not identifiers:
        raise fail(p, "an FMU with a co-simulation or model-exchange interface")
    import fmpy

    folder = fmpy.platform_tuple if version[0] == "3" else fmpy.platform
    binaries = {k: f"binaries/{folder}/{ident}{fmpy.sharedLibraryExtension}"
                for k, ident in identifiers.items()}
    binaries = {k: m for k, m in binaries.items() if m in names}
    if not binaries:
        shipped = sorted({n.split("/")[1] for n in names
                          if n.startswith("binaries/") and n.count("/") >= 2})
        has = (f"it has binaries for {', '.join(shipped)}" if shipped else
               "it has none (a source-only FMU must be compiled first)")
        want = " or ".join(sorted({f"binaries/{folder}/{i}{fmpy.sharedLibraryExtension}"
                                   for i in identifiers.values()}))
        raise fail(p, f"an FMU with a binary for this platform ({folder}): {want}; {has}")
    token = md.guid if md.guid is not None else getattr(md, "instantiationToken", "")
    return FmuFile(str(p), md, version, binaries, token or "")


def inspect(path: str | os.PathLike) -> FmuFile:
    """The checked FMU at ``path`` (cached per file state), or a one-line :class:`ConfigError`."""
    p = Path(path).expanduser()
    if not p.is_file():
        raise fail(p, "an existing FMU file (.fmu)")
    st = p.stat()
    return _inspect(str(p.resolve()), st.st_size, st.st_mtime_ns)


_FOLDERS: dict[tuple[str, int, int], Path] = {}


def extracted(path: str | os.PathLike) -> Path:
    """The folder this process extracted the FMU into (once per file state), checked again."""
    fmu = inspect(path)
    st = Path(fmu.path).stat()
    key = (fmu.path, st.st_size, st.st_mtime_ns)
    if key in _FOLDERS:
        return _FOLDERS[key]
    folder = Path(tempfile.mkdtemp(prefix="vpid-fmu-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    root = folder.resolve()
    total = 0
    with zipfile.ZipFile(fmu.path) as z:
        for info in _members(Path(fmu.path), z):
            target = (folder / info.filename).resolve()
            if root not in target.parents and target != root:
                raise fail(fmu.path, f"member names inside the FMU's folder; "
                           f"{info.filename} is not")
            if info.is_dir():
                target.mkdir(parents=True, exist_ok=True)
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            data = _read_limited(z, info, MAX_MEMBER_BYTES, Path(fmu.path))
            total += len(data)
            if total > MAX_TOTAL_BYTES:
                raise fail(fmu.path, f"an FMU of at most {MAX_TOTAL_BYTES // 1024**2} MiB "
                           "unpacked")
            with open(target, "xb") as fh:
                fh.write(data)
    _FOLDERS[key] = folder
    return folder
