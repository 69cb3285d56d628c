"""The variables of a MATLAB file, read within a memory budget.

Only the variables a recording needs are read: those its selectors name, or, without a
selector, the numeric arrays and structs (the candidates for the angle and the clock).  Before
any is read, the size each declares (elements x bytes per element, from the file's headers:
``scipy.io.whosmat`` for v4/v5/v7, the datasets' shapes for v7.3) is added up against
:data:`MAT_MAX_BYTES`; a compressed v5 variable is also unpacked once into nothing, counting its
bytes up to the same cap, since its nested arrays declare their sizes only inside the stream.  A
file that declares more is refused in one line naming the variable, whatever it holds on disk.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ...core.errors import DataError

__all__ = ["MAT_MAX_BYTES", "CHAR_MAX", "load_mat_variables"]

# bytes of variables read from one file: 5 x 10^7 doubles, a few signals of a 10^7-sample record
MAT_MAX_BYTES = 400 << 20
CHAR_MAX = 1 << 20  # characters of a text variable: a label or a note, never a signal
_ITEMSIZE = {"double": 8, "single": 4, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2, "int32": 4, "uint32": 4,
             "int64": 8, "uint64": 8, "logical": 1, "char": 4}
_MI_COMPRESSED = 15


class _Budget:
    """Bytes still allowed; each variable's declared size is taken before it is read."""

    def __init__(self, where: str) -> None:
        self.where = where
        self.left = MAT_MAX_BYTES

    def take(self, name: str, shape: tuple, kind: str) -> None:
        count = int(np.prod([int(d) for d in shape], dtype=object)) if shape else 1
        if kind == "char" and count > CHAR_MAX:
            raise DataError(f"variable {name!r} is text of {count:.4g} characters (more than {CHAR_MAX}): not part "
                            "of a recording; name the signals with [recording] angle_column", self.where)
        need = count * _ITEMSIZE.get(kind, 8)
        if need > self.left:
            raise DataError(f"variable {name!r} declares {'x'.join(map(str, shape)) or '1'} {kind} ({need / 1e6:.4g} "
                            f"MB): more than escfit reads of a recording ({MAT_MAX_BYTES / 1e6:.0f} MB in all); name "
                            "the signals with [recording] angle_column", self.where)
        self.left -= need


def _wanted(names: list[str], kinds: dict[str, str], roots: set[str] | None) -> list[str]:
    if roots is not None:
        return [n for n in names if n in roots]
    return [n for n in names if kinds[n] in _ITEMSIZE and kinds[n] != "char" or kinds[n] == "struct"]


def load_mat_variables(path: str | Path, roots: set[str] | None = None) -> tuple[dict[str, Any], dict[str, str], str]:
    """The variables of a .mat file, their kinds, and a description of its format.

    Parameters
    ----------
    path
        The .mat file.
    roots
        The variables to read; ``None``: the numeric arrays and structs.

    Returns
    -------
    variables, kinds, format
        ``kinds`` names every variable of the file with its MATLAB class (``double``, ``char``,
        ``struct``, ``cell`` ...), read or not.

    Raises
    ------
    DataError
        Unreadable files, v7.3 files without h5py, and variables declaring more than the budget.
    """
    where = str(path)
    with open(path, "rb") as fh:
        head = fh.read(520)
    if head.startswith(b"MATLAB 7.3") or head[512:520] == b"\x89HDF\r\n\x1a\n":
        return _load_v73(path, roots)
    from scipy.io import loadmat, whosmat

    try:
        listing = whosmat(str(path))
        kinds = {name: kind for name, _, kind in listing}
        wanted = _wanted(list(kinds), kinds, roots)
        budget = _Budget(where)
        for name, shape, kind in listing:
            if name in wanted:
                budget.take(name, tuple(shape), kind)
        if head.startswith(b"MATLAB 5.0") or head[126:128] in (b"IM", b"MI"):
            _check_packed(Path(path), [name for name, _, _ in listing], set(wanted), where)
        doc = loadmat(str(path), squeeze_me=True, struct_as_record=False, variable_names=wanted) if wanted else {}
    except DataError:
        raise
    except Exception as exc:  # scipy raises ValueError, TypeError, MatReadError ... for foreign files
        raise DataError(f"cannot read as a MATLAB file ({type(exc).__name__}: {exc})", where) from None
    version = "v5" if head.startswith(b"MATLAB 5.0") else "v4"
    return {k: v for k, v in doc.items() if not k.startswith("__")}, kinds, f"MATLAB {version} .mat"


def _check_packed(path: Path, names: list[str], wanted: set[str], where: str) -> None:
    """Unpack each wanted compressed variable of a v5 file into nothing, counting its bytes; one
    over the budget (or a stream that is not zlib) is refused before scipy reads it."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        fh.seek(126)
        order = "<" if fh.read(2) == b"IM" else ">"
        fh.seek(128)
        left, index = MAT_MAX_BYTES, 0
        while fh.tell() + 8 <= size:
            tag = fh.read(8)
            mdtype, nbytes = struct.unpack(order + "II", tag)
            start = fh.tell()
            if nbytes > size - start:
                raise DataError(f"variable {index + 1} declares {nbytes} bytes but the file has {size - start} left: "
                                "the file is cut short or damaged", where)
            name = names[index] if index < len(names) else None
            if mdtype == _MI_COMPRESSED and (name is None or name in wanted):
                left -= _unpacked_size(fh, nbytes, left, name or f"number {index + 1}", where)
            fh.seek(start + nbytes + (-nbytes % 8 if mdtype != _MI_COMPRESSED else 0))
            index += 1


def _unpacked_size(fh, nbytes: int, left: int, name: str, where: str) -> int:
    unpack = zlib.decompressobj()
    total, todo = 0, nbytes
    try:
        while todo > 0 and not unpack.eof:
            chunk = fh.read(min(todo, 1 << 20))
            if not chunk:
                break
            todo -= len(chunk)
            data = unpack.decompress(chunk, 1 << 22)
            while True:
                total += len(data)
                if total > left:
                    raise DataError(f"variable {name!r} unpacks to more than {left / 1e6:.0f} MB: more than escfit "
                                    f"reads of a recording ({MAT_MAX_BYTES / 1e6:.0f} MB in all); name the signals "
                                    "with [recording] angle_column", where)
                if not unpack.unconsumed_tail:
                    break
                data = unpack.decompress(unpack.unconsumed_tail, 1 << 22)
    except zlib.error as exc:
        raise DataError(f"variable {name!r} is damaged ({exc})", where) from None
    return total


def _load_v73(path: str | Path, roots: set[str] | None) -> tuple[dict[str, Any], dict[str, str], str]:
    where = str(path)
    try:
        import h5py
    except ImportError:
        raise DataError("a MATLAB v7.3 (HDF5) file needs h5py; save it with -v7 or install h5py", where) from None
    budget = _Budget(where)
    try:
        with h5py.File(path, "r") as f:
            kinds = {k: _h5_class(f[k]) for k in f if not k.startswith("#")}
            wanted = _wanted(list(kinds), kinds, roots)
            return ({k: _h5_value(f[k], f, budget, k) for k in wanted}, kinds, "MATLAB v7.3 .mat (HDF5)")
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise DataError(f"cannot read as a MATLAB v7.3 file ({exc})", where) from None


def _h5_class(node: Any) -> str:
    import h5py

    if isinstance(node, h5py.Group):
        return "struct"
    cls = node.attrs.get("MATLAB_class", b"double")
    return cls.decode() if isinstance(cls, bytes) else str(cls)


class _Struct:
    """A MATLAB struct read from HDF5, shaped like scipy's ``mat_struct``."""

    def __init__(self, fields: dict[str, Any]):
        self._fieldnames = list(fields)
        self.__dict__.update(fields)


def _h5_value(node: Any, f: Any, budget: _Budget, name: str, depth: int = 0) -> Any:
    import h5py

    if depth > 32:
        raise DataError(f"variable {name!r} nests structs or cells more than 32 deep", budget.where)
    child: Callable[[Any, str], Any] = lambda n, sub: _h5_value(n, f, budget, sub, depth + 1)  # noqa: E731
    if isinstance(node, h5py.Group):
        return _Struct({k: child(node[k], f"{name}.{k}") for k in node if not k.startswith("#")})
    cls = _h5_class(node)
    budget.take(name, tuple(node.shape), "double" if cls == "cell" else cls)
    data = node[()]
    if cls == "cell":
        refs = np.asarray(data).T
        out = np.empty(refs.shape, dtype=object)
        for idx, ref in np.ndenumerate(refs):
            out[idx] = child(f[ref], name)
        return out.squeeze() if out.size != 1 else out.ravel()[0]
    if cls == "char":
        return "".join(chr(c) for c in np.asarray(data).ravel())
    arr = np.asarray(data).T.squeeze()
    return arr[()] if arr.ndim == 0 else arr
