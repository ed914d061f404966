"""Reading what the CLI is given: CONFIG files and run folders, checked before use.

Every file is looked at with ``os.stat`` before it is opened: it must exist and be a regular file (a
FIFO, a socket, a device or a folder is refused without opening it, so nothing blocks or reads
forever) and no larger than a cap (:data:`MAX_TEXT_BYTES`, :data:`MAX_JSON_BYTES`,
:data:`MAX_NPZ_BYTES`). The open itself is non-blocking and checked again with ``fstat`` (a file
swapped for a FIFO in between is refused too), and at most cap + 1 bytes are read.

A run folder is read by :func:`read_run`: ``result.json`` parses and names a command the caller
accepts; ``config.toml`` is the configuration the result was computed from (its content hash,
:func:`birdocp.io.provenance.config_hash` of the parsed TOML, equals ``provenance.config_sha256`` of
``result.json``; a folder written before the hash existed is read with a warning); ``arrays.npz``
opens, every array in it reads back (CRC checked, no pickles), and :meth:`RunFolder.check_arrays`
checks their shapes. Every failure is a :class:`~birdocp.io.errors.ConfigError` on the flag that
named the folder (the CLI: exit 2, one line naming the folder, the file and the problem).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import stat
import tomllib
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from birdocp.io.errors import ConfigError

__all__ = ["MAX_TEXT_BYTES", "MAX_JSON_BYTES", "MAX_NPZ_BYTES", "MAX_NPZ_UNPACKED_BYTES", "file_problem",
           "read_input_bytes", "read_input_text", "read_json_file", "parse_toml", "toml_config_hash",
           "RunFolder", "read_run"]

MAX_TEXT_BYTES = 16 * 2**20
"""Largest CONFIG / config.toml accepted (16 MiB; a full configuration is about 2 kB)."""
MAX_JSON_BYTES = 1024 * 2**20
"""Largest JSON file of a run folder accepted (1 GiB; a 10000-point sweep's result.json is ~40 MB)."""
MAX_NPZ_BYTES = 4 * 2**30
"""Largest arrays.npz accepted (4 GiB on disk)."""
MAX_NPZ_UNPACKED_BYTES = 8 * 2**30
"""Largest total of the arrays in an arrays.npz once unpacked (8 GiB: a compressed bomb is refused)."""

_KINDS = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISDIR, "a folder"))


def _kind(mode: int) -> str:
    for test, name in _KINDS:
        if test(mode):
            return name
    return "not a regular file"


def _mib(n: int) -> str:
    return f"{n / 2**20:.3g} MiB"


def file_problem(path: str | Path, max_bytes: int | None = None) -> str | None:
    """Why ``path`` cannot be read as an input file; nothing is opened.

    Parameters
    ----------
    path : str or Path
        File to look at with ``os.stat``.
    max_bytes : int, optional
        Largest size accepted [bytes]; None: any size.

    Returns
    -------
    str or None
        The problem (missing, not a regular file -- FIFO, socket, device, folder --, unreadable, too
        large), worded to follow the file's name; None when the file can be read.
    """
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return "does not exist" if not os.path.islink(path) else f"is a dangling symbolic link (to '{os.readlink(path)}')"
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"
    if not stat.S_ISREG(st.st_mode):
        return f"is {_kind(st.st_mode)}, not a regular file"
    if max_bytes is not None and st.st_size > max_bytes:
        return f"is {_mib(st.st_size)}, more than the {_mib(max_bytes)} accepted"
    return None


def read_input_bytes(path: str | Path, key: str, *, what: str | None = None, max_bytes: int = MAX_TEXT_BYTES) -> bytes:
    """The bytes of the regular file ``path``, checked as by :func:`file_problem` and read non-blocking.

    Parameters
    ----------
    path : str or Path
        File to read.
    key : str
        Configuration key or flag that named the file: the key of the :class:`ConfigError`.
    what : str, optional
        How the messages name the file (default: the quoted path).
    max_bytes : int
        Largest size accepted [bytes].

    Returns
    -------
    bytes
        Content of the file.

    Raises
    ------
    ConfigError
        The file is missing, not a regular file, unreadable or larger than ``max_bytes``.
    """
    what = what or f"'{path}'"
    problem = file_problem(path, max_bytes)
    if problem:
        raise ConfigError(key, f"{what} {problem}")
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise ConfigError(key, f"{what} cannot be read ({exc.strerror or exc})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):  # swapped after the stat
            raise ConfigError(key, f"{what} is {_kind(st.st_mode)}, not a regular file")
        chunks, total = [], 0
        while True:
            chunk = os.read(fd, min(2**24, max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > max_bytes:
                raise ConfigError(key, f"{what} is more than the {_mib(max_bytes)} accepted")
    except OSError as exc:
        raise ConfigError(key, f"{what} cannot be read ({exc.strerror or exc})") from None
    finally:
        os.close(fd)
    return b"".join(chunks)


def read_input_text(path: str | Path, key: str, *, what: str | None = None, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """:func:`read_input_bytes` decoded as UTF-8 (a byte-order mark is dropped).

    Parameters
    ----------
    path : str or Path
        File to read.
    key : str
        Configuration key or flag that named the file: the key of the :class:`ConfigError`.
    what : str, optional
        How the messages name the file (default: the quoted path).
    max_bytes : int
        Largest size accepted [bytes].

    Returns
    -------
    str
        Content of the file; not UTF-8 is a :class:`ConfigError` on ``key``.
    """
    data = read_input_bytes(path, key, what=what, max_bytes=max_bytes)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise ConfigError(key, f"{what or repr(str(path))} is not UTF-8 text") from None


def read_json_file(path: str | Path, key: str, *, what: str | None = None, max_bytes: int = MAX_JSON_BYTES) -> Any:
    """The JSON value in ``path`` (checked as by :func:`read_input_bytes`).

    Parameters
    ----------
    path : str or Path
        File to read.
    key : str
        Configuration key or flag that named the file: the key of the :class:`ConfigError`.
    what : str, optional
        How the messages name the file (default: the quoted path).
    max_bytes : int
        Largest size accepted [bytes].

    Returns
    -------
    Any
        The parsed value; a file that does not parse (truncated, not JSON, nested too deep) is a
        :class:`ConfigError` on ``key``.
    """
    what = what or f"'{path}'"
    text = read_input_text(path, key, what=what, max_bytes=max_bytes)
    try:
        return json.loads(text)
    except RecursionError:
        raise ConfigError(key, f"{what} is nested too deeply to be a birdocp file") from None
    except ValueError as exc:
        raise ConfigError(key, f"{what} is not valid JSON (truncated or damaged? {exc})") from None


def parse_toml(text: str, key: str, what: str = "the configuration") -> dict:
    """The TOML document ``text`` as a dict.

    Parameters
    ----------
    text : str
        TOML document.
    key : str
        Configuration key or flag that named the document: the key of the :class:`ConfigError`.
    what : str
        How the messages name the document.

    Returns
    -------
    dict
        The parsed document; not TOML, nested too deeply (thousands of tables) or a number too long to
        read is a :class:`ConfigError` on ``key``.
    """
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(key, f"{what} is not valid TOML: {exc}") from None
    except RecursionError:
        raise ConfigError(key, f"{what} is nested too deeply (tables within tables); a birdocp configuration "
                               "has two or three levels") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise ConfigError(key, f"{what} holds a value that cannot be read: {exc}") from None


def toml_config_hash(data: dict) -> str:
    """:func:`birdocp.io.provenance.config_hash` of a parsed configuration.

    Parameters
    ----------
    data : dict
        Parsed configuration (e.g. a run folder's config.toml).

    Returns
    -------
    str
        Hexadecimal SHA-256 of its canonical TOML text: the same hash as the configuration it was
        written from.
    """
    from birdocp.io.provenance import canonical_toml

    return hashlib.sha256(canonical_toml(data).encode("utf-8")).hexdigest()


@dataclass
class RunFolder:
    """A run folder read by :func:`read_run`.

    path:        the folder.
    key:         the flag that named it (``RUN_DIR``, ``--controller``): the key of every error.
    result:      result.json (a dict).
    command:     ``provenance.command`` of result.json (None when it names none).
    config_text: config.toml as text (None when not read).
    config_data: config.toml parsed (a dict; None when not read).
    arrays:      the arrays of arrays.npz (None when not read or absent).
    warnings:    one line each (e.g. a folder written before the configuration hash existed).
    """

    path: Path
    key: str
    result: dict
    command: str | None
    config_text: str | None = None
    config_data: dict | None = None
    arrays: dict | None = None
    warnings: list = field(default_factory=list)

    def error(self, file: str, problem: str) -> ConfigError:
        """The :class:`ConfigError` of ``problem`` with ``file`` of this folder."""
        return ConfigError(self.key, f"'{self.path}': {file}: {problem}")

    def check_arrays(self, shapes: dict[str, Sequence[int | None]], required: bool = True) -> None:
        """Check that arrays.npz holds arrays of these shapes (``None``: any length on that axis);
        ``required``: a missing array is an error (else only arrays present are checked)."""
        arrays = self.arrays or {}
        for name, shape in shapes.items():
            a = arrays.get(name)
            if a is None:
                if required:
                    raise self.error("arrays.npz", f"holds no array '{name}' (a run of another kind, or damaged)")
                continue
            ok = a.ndim == len(shape) and all(n is None or n == m for n, m in zip(shape, a.shape))
            if not ok:
                want = "(" + ", ".join("any" if n is None else str(n) for n in shape) + ("," if len(shape) == 1 else "") + ")"
                raise self.error("arrays.npz", f"'{name}' has shape {tuple(a.shape)}, the stored configuration "
                                               f"needs {want}; the arrays do not belong to this configuration")


def _folder(path: Path, key: str) -> None:
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise ConfigError(key, f"'{path}' does not exist; give a run folder") from None
    except OSError as exc:
        raise ConfigError(key, f"'{path}' cannot be read ({exc.strerror or exc})") from None
    if not stat.S_ISDIR(st.st_mode):
        raise ConfigError(key, f"'{path}' is {_kind(st.st_mode) if not stat.S_ISREG(st.st_mode) else 'a file'}, "
                               "not a run folder")


def _read_npz(run: RunFolder) -> dict:
    import numpy as np

    data = read_input_bytes(run.path / "arrays.npz", run.key, what=f"'{run.path}': arrays.npz",
                            max_bytes=MAX_NPZ_BYTES)
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            unpacked = sum(i.file_size for i in zf.infolist())
        if unpacked > MAX_NPZ_UNPACKED_BYTES:
            raise run.error("arrays.npz", f"unpacks to {_mib(unpacked)}, more than the "
                                          f"{_mib(MAX_NPZ_UNPACKED_BYTES)} accepted")
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        for k, a in arrays.items():
            if not isinstance(a, np.ndarray) or a.dtype.hasobject:
                raise run.error("arrays.npz", f"'{k}' is not a numeric array (not an arrays.npz birdocp wrote)")
        return arrays
    except ConfigError:
        raise
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, KeyError, NotImplementedError) as exc:
        raise run.error("arrays.npz", f"cannot be read (truncated or damaged: {type(exc).__name__}: "
                                      f"{' '.join(str(exc).split())[:200]}); run the command again") from None


def _check_config(run: RunFolder) -> None:
    run.config_text = read_input_text(run.path / "config.toml", run.key, what=f"'{run.path}': config.toml")
    run.config_data = parse_toml(run.config_text, run.key, f"'{run.path}': config.toml")
    prov = run.result.get("provenance")
    stored = prov.get("config_sha256") if isinstance(prov, dict) else None
    if stored is None:
        run.warnings.append(f"'{run.path}' was written without a configuration hash (provenance.config_sha256): "
                            "its config.toml is taken to be the one its result was computed from")
        return
    if toml_config_hash(run.config_data) != stored:
        raise run.error("config.toml", "is not the configuration the result was computed from (its sha256 differs "
                                       "from provenance.config_sha256 in result.json: edited or swapped); restore "
                                       "the run's own config.toml or run the command again")


def read_run(path: str | Path, key: str = "RUN_DIR", *, commands: Sequence[str] | None = None,
             config: bool = True, arrays: str | None = "optional", kind: str = "a run folder",
             hint: str | None = None) -> RunFolder:
    """Read and check the run folder ``path`` (see the module's text).

    Parameters
    ----------
    path : str or Path
        Run folder to read.
    key : str
        The flag that named the folder: the key of every :class:`ConfigError`.
    commands : sequence of str, optional
        The commands (``provenance.command``) whose folders are accepted; None: any.
    config : bool
        Read config.toml (required) and check it against ``provenance.config_sha256``.
    arrays : {"required", "optional", None}
        Read arrays.npz: it must exist; read it when it exists; do not read it.
    kind : str
        What the caller wants, for the messages (e.g. "a trim or level run folder").
    hint : str, optional
        The fix named when the command is not one of ``commands`` (default: give ``kind``).

    Returns
    -------
    RunFolder
        The folder's result, configuration and arrays, checked.
    """
    path = Path(path)
    _folder(path, key)
    result = read_json_file(path / "result.json", key, what=f"'{path}': result.json")
    if not isinstance(result, dict) or not isinstance(result.get("provenance", {}), dict):
        raise ConfigError(key, f"'{path}': result.json: is not a birdocp result (a JSON object with provenance)")
    command = (result.get("provenance") or {}).get("command")
    if commands is not None and command not in commands:
        names = " or ".join(f"'{c}'" for c in commands)
        what = f"a '{command}' run" if command else "a result that names no birdocp command"
        raise ConfigError(key, f"'{path}': result.json: is {what}; " + (hint or f"give {kind} (of {names})"))
    run = RunFolder(path, key, result, command if isinstance(command, str) else None)
    if config:
        _check_config(run)
    npz = path / "arrays.npz"
    if arrays == "required" or (arrays == "optional" and os.path.lexists(npz)):
        run.arrays = _read_npz(run)
    return run
