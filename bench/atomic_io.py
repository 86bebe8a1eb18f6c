"""Atomic file writes for the bench scripts: each writes a temporary file in the target's folder
(TARGET.tmp.PID.HEX, which .gitignore's *.tmp.* covers), flushes it to disk, then moves it onto
the target with os.replace, so a reader sees the old file or the whole new one, never a part; the
temporary file is removed if writing fails (an exception, Ctrl-C included).

The scripts of bench/ import it by name (`from atomic_io import write_json`): Python puts a
script's own folder first on sys.path, and the scripts that import other bench scripts put bench/
there themselves.

    write_json(path, obj, **json_kwargs)   json.dump(obj, f, **json_kwargs), nothing added
    write_text(path, text)                 the text as it is (no newline added)
    with atomic_open(path) as f: ...       a file object to write in pieces
    with replacing(path) as tmp: ...       a file name for another program to write (rsvg-convert -o)
"""
import contextlib
import json
import os
import secrets


def _create_beside(path):
    """A new empty file next to path, named for it; its permissions are open()'s (0666 less the
    umask). Returns (name, fd)."""
    while True:
        tmp = f"{path}.tmp.{os.getpid()}.{secrets.token_hex(4)}"
        try:
            return tmp, os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue


def _remove(tmp):
    try:
        os.remove(tmp)
    except FileNotFoundError:
        pass


@contextlib.contextmanager
def replacing(path):
    """Yields the name of a new empty temporary file beside path, for a writer that takes a file
    name; on leaving the block without an exception the file replaces path, on an exception it is
    removed."""
    tmp, fd = _create_beside(path)
    os.close(fd)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        _remove(tmp)
        raise


@contextlib.contextmanager
def atomic_open(path, mode="w", **open_kwargs):
    """open(path, mode, **open_kwargs) (a write mode: "w" or "wb") onto a temporary file beside
    path: flushed, synced and moved onto path on leaving the block, removed on an exception."""
    if not mode.startswith("w"):
        raise ValueError(f"atomic_open: mode {mode!r} is not a write mode")
    tmp, fd = _create_beside(path)
    try:
        f = open(fd, mode, **open_kwargs)
    except BaseException:
        os.close(fd)
        _remove(tmp)
        raise
    try:
        with f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        _remove(tmp)
        raise


def write_text(path, text, **open_kwargs):
    """Writes text to path atomically, as open(path, "w", **open_kwargs).write(text) would."""
    with atomic_open(path, "w", **open_kwargs) as f:
        f.write(text)


def write_json(path, obj, **json_kwargs):
    """Writes obj to path atomically as json.dump(obj, f, **json_kwargs) would (indent,
    sort_keys...; no trailing newline unless the caller writes one)."""
    with atomic_open(path, "w") as f:
        json.dump(obj, f, **json_kwargs)
