"""Write files so that they appear only when complete, and never over an input.

Every file kinsync writes goes through `atomic_path`: the data go to a hidden
temporary beside the output (``.NAME.PID.XXXXXXXX.part``, a NAME over 200 bytes
shortened with a hash), renamed onto the output
only when complete, and removed on any error or interruption. Two rules hold for
every output by construction:

* **An output never replaces an input.** Inside `protected_inputs` (the command line
  wraps every command in it, with every input file and folder it was given),
  `atomic_path` refuses a target that is one of those files (by any path: relative,
  through a symbolic or a hard link) or an existing file inside an input folder,
  figures and reports excepted (kinsync never reads ``.png``, ``.svg``, ``.pdf`` or
  ``.html``).
* **Nothing is left behind.** A temporary left by a killed run (its process no longer
  exists) is removed when the same output is written next.

An output given as a symbolic link is written to the file the link points to, as
``cp`` or a shell redirection would: the link stays, and the temporary goes beside its
target (`write_target`), so that the rename stays on one file system.

A folder of outputs written as one whole (a simulation, the demo report) goes through
`atomic_folder`: it is written into a hidden temporary folder beside it
(``.NAME.PID.XXXXXXXX.part``) and published by renames, so that the folder holds either
its complete old content or its complete new content, never a mix.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import hashlib
import os
import re
import shutil
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import ExitStack, contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

from kinsync._signals import stop_signals_held
from kinsync.errors import DiskFullError, InputError, KinsyncError
from kinsync.io.sanity import check_name_length, check_not_link_loop

__all__ = [
    "ProtectedInput",
    "atomic_folder",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "cannot_write_error",
    "check_not_an_input",
    "check_output_location",
    "disk_full_error",
    "finish_then_publish",
    "full_disk_cause",
    "named_outputs",
    "output_folder",
    "protected_inputs",
    "published_together",
    "write_target",
]

WRITE_ONLY_SUFFIXES = frozenset({".png", ".svg", ".pdf", ".html"})
"""Suffixes of files kinsync writes (figures, reports) but never reads."""


@dataclass(frozen=True)
class ProtectedInput:
    """An input file or folder that no output may replace.

    Attributes
    ----------
    path : Path
        The file or folder as given.
    label : str
        How to name it in a message (e.g. ``"--points lines/a.laz"``).
    """

    path: Path
    label: str


_PROTECTED: ContextVar[tuple[ProtectedInput, ...]] = ContextVar("kinsync_protected_inputs")

_NAMED: ContextVar[tuple[tuple[Path, str], ...]] = ContextVar("kinsync_named_outputs")
"""Outputs as the command line names them (``--out small/g10.csv``), by path."""

_FOLDERS_BEING_WRITTEN: ContextVar[tuple[tuple[Path, Path], ...]] = ContextVar(
    "kinsync_folders_being_written"
)
"""(temporary folder, output folder) of each `atomic_folder` block being written."""

_HELD: ContextVar[list[tuple[Path, Path, Path]] | None] = ContextVar(
    "kinsync_held_outputs", default=None
)
"""(temporary, output, file renamed onto: `write_target`) of each complete file waiting
for its `published_together` block."""

FULL_DISK_ERRNOS = frozenset(
    {errno.ENOSPC, errno.EFBIG, *([errno.EDQUOT] if hasattr(errno, "EDQUOT") else [])}
)
"""Error numbers of a full disk (ENOSPC), of a full disk quota (EDQUOT) and of a file
grown beyond what its file system or the process may write (EFBIG: FAT32's 4 GiB, a
``ulimit -f``): each stops an output for want of room, not for a fault of kinsync."""


@contextmanager
def protected_inputs(inputs: Iterable[ProtectedInput]) -> Iterator[None]:
    """Within this block, `atomic_path` refuses to replace any of ``inputs``."""
    token = _PROTECTED.set((*_PROTECTED.get(()), *inputs))
    try:
        yield
    finally:
        _PROTECTED.reset(token)


@contextmanager
def named_outputs(outputs: Iterable[tuple[str, Path]]) -> Iterator[None]:
    """Within this block, messages name these outputs by their option (``--out PATH``).

    Parameters
    ----------
    outputs : iterable of (str, Path)
        Each output's command-line option (e.g. ``"--out"``) and path as given.
    """
    named = tuple((Path(os.path.abspath(p)), f"{option} {p}") for option, p in outputs)  # noqa: PTH100
    token = _NAMED.set((*_NAMED.get(()), *named))
    try:
        yield
    finally:
        _NAMED.reset(token)


def _shown_output(path: Path) -> str:
    """How a message names output ``path``: by its option when the command line gave it.

    A file written inside the temporary folder of an `atomic_folder` block is named by
    its place in the output folder (of each block, for blocks one inside another).
    """
    where = Path(os.path.abspath(path))  # noqa: PTH100
    for tmp, final in reversed(_FOLDERS_BEING_WRITTEN.get(())):  # the innermost first
        if where.is_relative_to(tmp):
            where = final / where.relative_to(tmp)
            path = where
    for named, label in _NAMED.get(()):
        if named == where:
            return label
    return str(path)


def full_disk_cause(err: BaseException) -> OSError | None:
    """The full-disk, full-quota or file-too-large `OSError` behind ``err``, if any.

    ``err`` itself or one of its causes (`FULL_DISK_ERRNOS`).

    A `KinsyncError` already says what went wrong: none is looked for behind it.
    """
    seen: BaseException | None = err
    for _ in range(16):  # causes chain; a cycle cannot hang
        if seen is None or isinstance(seen, KinsyncError):
            return None
        if isinstance(seen, OSError) and seen.errno in FULL_DISK_ERRNOS:
            return seen
        seen = seen.__cause__ or seen.__context__
    return None


def disk_full_error(path: Path | str, err: OSError) -> DiskFullError:
    """The one-line error for an output that a full disk (or quota, or a size limit) cut short.

    Parameters
    ----------
    path : Path or str
        The output being written (named by its option when the command line gave it).
    err : OSError
        The error, ``ENOSPC``, ``EDQUOT`` or ``EFBIG``.
    """
    shown = _shown_output(Path(path)) if isinstance(path, Path) else path
    if err.errno == errno.EFBIG:
        msg = (
            f"{shown}: the file has grown beyond the largest file this file system or the "
            f"process's file-size limit (ulimit -f) allows ({err.strerror or err}); the "
            "output is not written (nothing partial is left): write it to another file "
            "system (FAT32 holds at most 4 GiB), raise the limit, or make it smaller "
            "(split the input, or write LAZ rather than LAS or CSV), then run again"
        )
        return DiskFullError(msg)
    quota = hasattr(errno, "EDQUOT") and err.errno == errno.EDQUOT
    what = "the disk quota is exceeded" if quota else "the disk is full"
    todo = (
        "free space in your quota (or ask for a larger one)" if quota else "free space on that disk"
    )
    msg = (
        f"{shown}: {what} ({err.strerror or err}); the output is not written (nothing "
        f"partial is left): {todo}, or write the output to another disk, then run again"
    )
    return DiskFullError(msg)


def cannot_write_error(path: Path, err: OSError, what: str = "cannot write") -> InputError:
    """The one-line error for an output that ``err`` stopped: a full disk as `disk_full_error`.

    Parameters
    ----------
    path : Path
        The output being written (named by its option when the command line gave it).
    err : OSError
        The error of the write.
    what : str
        What failed, for any other error (``"{path}: {what} ({reason})"``).
    """
    full = full_disk_cause(err)
    if full is not None:
        return disk_full_error(path, full)
    return InputError(f"{path}: {what} ({err.strerror or err})")


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.samefile(b)
    except OSError:  # one of them does not exist (yet)
        return a.resolve() == b.resolve()


def check_not_an_input(
    path: Path, inputs: Iterable[ProtectedInput] | None = None, option: str = ""
) -> None:
    """Refuse an output ``path`` that would replace one of ``inputs``.

    Parameters
    ----------
    path : Path
        The output file.
    inputs : iterable of ProtectedInput, optional
        The inputs; default: those of the enclosing `protected_inputs` block.
    option : str
        Command-line option naming the output in the message (e.g. ``"--out"``).

    Raises
    ------
    InputError
        ``path`` is an input file (by any path), an input folder, or an existing
        file inside an input folder (figures and reports excepted); ``path`` or an
        input is a loop of symbolic links.
    """
    path = Path(path)
    shown = f"{option} {path}" if option else str(path)
    check_not_link_loop(path, "output file", shown)
    for item in _PROTECTED.get(()) if inputs is None else inputs:
        check_not_link_loop(item.path, "input", item.label)
        if item.path.is_dir():
            if _same_file(path, item.path):
                msg = f"{shown}: is the input folder {item.label}; give an output file"
                raise InputError(msg)
            inside = path.resolve().is_relative_to(item.path.resolve())
            if inside and path.is_file() and path.suffix.lower() not in WRITE_ONLY_SUFFIXES:
                msg = (
                    f"{shown}: would replace a file of the input folder {item.label}; "
                    "write the output elsewhere"
                )
                raise InputError(msg)
        elif _same_file(path, item.path):
            msg = f"{shown}: is the input {item.label}; write the output to another file"
            raise InputError(msg)


def _probe_writable(folder: Path, shown: str) -> None:
    """Create and remove a temporary file in ``folder``: the one sure test of writing.

    ``os.access`` is not (root passes it on folders it cannot write, such as /sys).
    """
    try:
        fd, name = tempfile.mkstemp(prefix=f".kinsync.{os.getpid()}.", suffix=".part", dir=folder)
    except OSError as err:
        why = err.strerror or err
        msg = f"{shown}: cannot write in the folder {folder} ({why}); choose another"
        raise InputError(msg) from None
    os.close(fd)
    with contextlib.suppress(OSError):
        Path(name).unlink()


def write_target(path: Path) -> Path:
    """The file an output ``path`` is written to: the target of a symbolic link.

    Renaming a temporary onto a link would replace the link itself with a regular file,
    and the file it points to (perhaps missing: a dangling link) would never receive the
    output. The link is followed to its end, as ``cp`` or a shell redirection would.

    Parameters
    ----------
    path : Path
        The output as given.

    Returns
    -------
    Path
        ``path`` itself when it is not a symbolic link; otherwise the path the link
        (and any link it points to) resolves to, which may not exist yet.
    """
    path = Path(path)
    if not path.is_symlink():
        return path
    return Path(os.path.realpath(path))


def check_output_location(path: Path, option: str = "", *, folder: bool = False) -> None:
    """Refuse an output that cannot be written there, before any work is done.

    Parameters
    ----------
    path : Path
        The output file, or folder (``folder=True``).
    option : str
        Command-line option naming it in the message (e.g. ``"--out"``).
    folder : bool
        The output is a folder (created if missing, in an existing folder) rather than a
        file.

    Raises
    ------
    InputError
        A file output that is an existing folder or whose folder does not exist; a
        folder output that is an existing file, lies below one, is the current folder
        (``.``) or one above it, or whose parent folder does not exist; a location where
        no file can be created (permissions, a read-only or virtual file system).
    """
    path = Path(path)
    shown = f"{option} {path}" if option else str(path)
    if folder:
        if path.exists() and not path.is_dir():
            msg = f"{shown}: exists and is not a folder; give a folder for the output"
            raise InputError(msg)
        _check_folder_location(path, shown)
        probe = path if path.is_dir() else Path(os.path.abspath(path)).parent  # noqa: PTH100
    else:
        if path.is_dir():
            msg = f"{shown}: is an existing folder; give a file name for the output"
            raise InputError(msg)
        target = write_target(path)
        probe = target.parent if str(target.parent) else Path()
        if not probe.is_dir():
            msg = f"{shown}: output folder {probe} does not exist; create it first"
            raise InputError(msg)
    _probe_writable(probe, shown)


def _check_not_the_current_folder(path: Path, shown: str) -> None:
    """Refuse a folder output that is the current folder (``.``, ``""``) or one above it.

    A folder output is written beside itself and renamed into place, replacing the folder
    as a whole: the current folder would be swapped out from under the shell that runs
    the command (left in a removed folder).
    """
    absolute = Path(os.path.abspath(path))  # noqa: PTH100 - normalises "..", keeps links
    cwd = Path.cwd()
    if absolute == cwd or cwd.is_relative_to(absolute):
        what = "the current folder" if absolute == cwd else "a folder above the current one"
        msg = (
            f"{shown}: is {what} ({absolute}); the output replaces its folder as a whole, "
            "so give a new folder's name (e.g. --out results) instead"
        )
        raise InputError(msg)


def _check_folder_location(path: Path, shown: str) -> None:
    """Refuse a folder output that is the current folder or whose parent is missing.

    The folder itself may be missing (it is created), but the folder that holds it must
    exist, as for a file output.
    """
    _check_not_the_current_folder(path, shown)
    if path.is_dir():
        return
    parent = Path(os.path.abspath(path)).parent  # noqa: PTH100
    probe = parent
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        msg = f"{shown}: {probe} is a file, not a folder; give a folder for the output"
        raise InputError(msg)
    if probe != parent:
        msg = f"{shown}: output folder {path.parent} does not exist; create it first"
        raise InputError(msg)


LONGEST_PLAIN_STEM_BYTES = 200
"""The longest output name a temporary repeats whole: a temporary adds about 32 bytes
(``.``, ``.PID.XXXXXXXX.hTAG.part``), and a name may have 255 on most file systems."""


def _temp_stem(name: str) -> str:
    """The output ``name`` as its temporaries spell it: whole, or shortened with a hash.

    A name near the file system's limit (226 to 255 bytes) left no room for the
    temporary's own characters: such an output was refused ("File name too long"). A
    long name keeps its first 100 bytes and a hash of the whole, so that temporaries of
    different outputs still differ and a killed run's are still found.
    """
    raw = os.fsencode(name)
    if len(raw) <= LONGEST_PLAIN_STEM_BYTES:
        return name
    digest = hashlib.sha256(raw).hexdigest()[:16]
    return f"{raw[:100].decode('utf-8', 'ignore')}~{digest}"


_PART = re.compile(r"(?P<pid>\d+)\.[^.]+(?:\.h(?P<tag>[0-9a-f]{8}))?\.(?P<kind>part|old)")

FOREIGN_STALE_S = 24 * 3600.0
"""Age (s) past which a temporary of another machine or container is taken as stale."""


@functools.lru_cache(maxsize=1)
def writer_tag() -> str:
    """Eight hex digits naming this machine, boot and PID namespace (in temporaries' names).

    A temporary's process id means something only where it was written: two containers
    sharing a volume, or two hosts sharing an NFS folder, each see their own processes,
    and a live writer's temporary looked stale to the other (``kill(pid, 0)`` found no
    such process) and was removed under it. A temporary whose tag is another's is
    removed only once older than `FOREIGN_STALE_S`.
    """
    parts = [os.uname().nodename if hasattr(os, "uname") else ""]
    with contextlib.suppress(OSError):
        parts.append(Path("/proc/sys/kernel/random/boot_id").read_text().strip())
    with contextlib.suppress(OSError):
        parts.append(str(Path("/proc/self/ns/pid").stat().st_ino))
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()[:8]


def _temp_suffix(kind: str) -> str:
    """A temporary's suffix: this writer's tag (`writer_tag`) and its kind."""
    return f".h{writer_tag()}.{kind}"


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    return True


def _remove_stale_parts(parent: Path, name: str) -> None:
    """Remove temporaries of ``parent/name`` whose writing process no longer exists.

    The process is looked for only when the temporary was written here (its tag is
    `writer_tag`, or it has none); another machine's or container's is removed once
    older than `FOREIGN_STALE_S`.

    A temporary file or folder (``.part``) is removed. A folder set aside while
    publishing (``.old``, see `atomic_folder`) is put back when ``parent/name`` is
    missing (the run was killed between the two renames), removed otherwise.
    """
    prefix = f".{_temp_stem(name)}."
    with contextlib.suppress(OSError):
        for entry in sorted(os.scandir(parent), key=lambda e: e.name):
            if not entry.name.startswith(prefix):
                continue
            match = _PART.fullmatch(entry.name[len(prefix) :])
            if match is None:
                continue
            if match["tag"] not in (None, writer_tag()):  # another machine or container
                with contextlib.suppress(OSError):
                    age_s = time.time() - entry.stat(follow_symlinks=False).st_mtime
                    if age_s < FOREIGN_STALE_S:
                        continue
            elif _process_alive(int(match["pid"])):
                continue
            stale = Path(entry.path)
            with contextlib.suppress(OSError):
                if entry.is_file(follow_symlinks=False):
                    if match["kind"] == "part":
                        stale.unlink()
                elif entry.is_dir(follow_symlinks=False):
                    target = parent / name
                    if match["kind"] == "old" and not target.exists():
                        stale.rename(target)
                    else:
                        shutil.rmtree(stale)


_PUBLISHED: list[Path] = []
"""Outputs renamed into place by this process, in order."""


def published_count() -> int:
    """How many outputs this process has published so far (a mark for `published_since`)."""
    return len(_PUBLISHED)


def published_since(mark: int) -> list[Path]:
    """The outputs published after ``mark`` that are still there.

    A file published into a folder that is itself published later (`atomic_folder`)
    is gone with the temporary folder when the run stops before that: it is left out.
    """
    return [p for p in dict.fromkeys(_PUBLISHED[mark:]) if p.exists()]


@contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On any exception (an interruption included) the temporary file is removed and
    ``path`` is left untouched. Refuses a ``path`` that is an input of the enclosing
    `protected_inputs` block, an existing folder, or in a folder that is missing or
    not writable.
    """
    path = Path(path)
    check_name_length(path, _shown_output(path))  # a name over 255 bytes: said plainly
    check_not_an_input(path)
    target = write_target(path)  # a symbolic link: the file it points to
    parent = target.parent if str(target.parent) else Path()
    if not parent.is_dir():
        msg = f"{path}: output folder {parent} does not exist; create it first"
        raise InputError(msg)
    if path.is_dir():
        msg = f"{path}: is an existing folder; give a file name for the output"
        raise InputError(msg)
    _remove_stale_parts(parent, target.name)
    try:
        fd, tmp_name = tempfile.mkstemp(
            prefix=f".{_temp_stem(target.name)}.{os.getpid()}.",
            suffix=_temp_suffix("part"),
            dir=parent,
        )
    except OSError as err:
        msg = f"{path}: cannot write in the folder {parent} ({err.strerror or err}); choose another"
        raise InputError(msg) from None
    os.close(fd)
    tmp = Path(tmp_name)
    umask = os.umask(0)
    os.umask(umask)
    tmp.chmod(0o666 & ~umask)  # mkstemp creates 0600; give the file the usual mode
    held = False
    try:
        try:
            yield tmp
        except Exception as err:
            full = full_disk_cause(err)
            if full is not None:
                raise disk_full_error(path, full) from None
            raise
        waiting = _HELD.get()
        if waiting is not None:  # renamed with the others when the block ends
            waiting.append((tmp, path, target))
            held = True
            return
        with stop_signals_held():  # renamed and recorded, or neither
            _publish_file(tmp, path, target)
    finally:
        if not held:
            tmp.unlink(missing_ok=True)


def _publish_file(tmp: Path, path: Path, target: Path) -> None:
    """Rename the complete temporary ``tmp`` onto ``target`` and record ``path`` as published.

    ``target`` is ``path``, or the file it points to when ``path`` is a symbolic link
    (`write_target`): the link is kept.
    """
    try:
        tmp.replace(target)
        _PUBLISHED.append(path)
    except OSError as err:  # e.g. an existing file made immutable (chattr +i)
        msg = (
            f"{path}: cannot replace it ({err.strerror or err}); the output is not "
            "written: make the file writable or choose another"
        )
        raise InputError(msg) from None


@contextmanager
def published_together() -> Iterator[None]:
    """Within this block, files complete in `atomic_path` wait; all are renamed at its end.

    For outputs that belong together (a georeferenced file and the file of its rejected
    points): none replaces an earlier file until every one is complete. On any
    exception (an interruption included) the waiting temporaries are removed and every
    earlier file is left as it was.
    """
    waiting: list[tuple[Path, Path, Path]] = []
    token = _HELD.set(waiting)
    try:
        try:
            yield
        finally:
            _HELD.reset(token)
        with stop_signals_held():  # renamed and recorded, or neither (each)
            for tmp, path, target in waiting:
                _publish_file(tmp, path, target)
    finally:
        for tmp, _, _ in waiting:
            tmp.unlink(missing_ok=True)


def finish_then_publish(
    stack: ExitStack,
    finish: Callable[[], None],
    exc_type: type[BaseException] | None,
    exc: BaseException | None,
    tb: TracebackType | None,
) -> None:
    """End a streaming writer whose `atomic_path` is held in ``stack``.

    ``finish`` writes the last bytes and closes the file (header counts, trailing
    records). The stack is then closed with the block's own exception, so the file is
    renamed into place only after a clean block. If ``finish`` itself fails, the stack
    is closed with that error (the temporary file is removed) and it propagates.
    """
    try:
        finish()
    except BaseException as err:
        stack.__exit__(type(err), err, err.__traceback__)
        raise
    stack.__exit__(exc_type, exc, tb)


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and an atomic rename."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def atomic_write_text(path: Path, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` through a temporary file and an atomic rename."""
    atomic_write_bytes(path, text.encode("utf-8"))


def output_folder(path: Path, hint: str, *, create: bool = True, option: str = "") -> Path:
    """Check that ``path`` can be an output folder (absent or a folder); create it.

    Parameters
    ----------
    path : Path
        The folder.
    hint : str
        What to do instead, ending the error message (e.g. "give a folder for the
        simulation").
    create : bool
        Create the folder (and its parents) when it is missing.
    option : str
        Command-line option naming the folder in the message (e.g. "--out"), if any.

    Raises
    ------
    InputError
        ``path`` exists and is not a folder, or cannot be created.
    """
    path = Path(path)
    prefix = f"{option} " if option else ""
    if path.exists() and not path.is_dir():
        msg = f"{prefix}{path}: exists and is not a folder; {hint}"
        raise InputError(msg)
    if create:
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            msg = f"{prefix}{path}: cannot create the folder ({err.strerror}); {hint}"
            raise InputError(msg) from None
    return path


def _publish_folder(new: Path, path: Path) -> None:
    """Rename the complete folder ``new`` onto ``path``, setting an existing one aside.

    The old folder is renamed to ``.NAME.PID.XXXXXXXX.old``, the new one into place, then
    the old one removed. If the second rename fails or is interrupted, the old folder is
    put back; if the process is killed between the renames, the next `atomic_folder` of
    ``path`` puts it back.
    """
    if not path.exists():
        new.rename(path)
        return
    prefix = f".{_temp_stem(path.name)}.{os.getpid()}."
    old = Path(tempfile.mkdtemp(prefix=prefix, suffix=_temp_suffix("old"), dir=new.parent))
    old.rmdir()  # only the unique name is wanted: rename needs a missing (or empty) target
    path.rename(old)
    try:
        new.rename(path)
    except BaseException:
        if not path.exists():
            old.rename(path)
        raise
    shutil.rmtree(old, ignore_errors=True)


@contextmanager
def atomic_folder(
    path: Path, check: Callable[[Path], None], hint: str, *, option: str = ""
) -> Iterator[Path]:
    """Yield a fresh hidden folder beside ``path``; publish it as ``path`` on success.

    Everything written into the yielded folder appears at ``path`` at once, when the
    block ends without an error: ``path`` then holds the complete new content, and its
    earlier content (if any) is removed. On any exception (an interruption included)
    the temporary folder is removed and ``path`` is left exactly as it was. Temporaries
    left by a killed run are cleaned up (or, for a set-aside old folder, put back) on
    the next call.

    Parameters
    ----------
    path : Path
        The output folder: missing, or an existing folder that ``check`` accepts to
        replace as a whole (a symbolic link to a folder: the folder it points to).
    check : callable
        Called with ``path`` when it exists, before anything is written and again just
        before publishing; raises `InputError` when the folder holds anything that must
        not be replaced (files of the user's).
    hint : str
        What to do instead, ending the error messages (e.g. "give a folder for the
        simulation").
    option : str
        Command-line option naming the folder in messages (e.g. "--out"), if any.

    Raises
    ------
    InputError
        ``path`` exists and is not a folder, is the current folder or one above it,
        ``check`` refuses it, or its parent folder cannot be created or written (a
        command refuses a missing parent folder before any work:
        `check_output_location`).
    """
    path = Path(path)
    prefix = f"{option} " if option else ""
    if path.exists() and not path.is_dir():
        msg = f"{prefix}{path}: exists and is not a folder; {hint}"
        raise InputError(msg)
    _check_not_the_current_folder(path, f"{prefix}{path}")
    # The temporary folder goes beside the output, in the folder that holds it: resolved
    # first, since Path(".").parent is "." itself (the temporary would land inside).
    if path.is_symlink() and path.is_dir():
        path = Path(os.path.realpath(path))
    given, path = path, Path(os.path.abspath(path))  # noqa: PTH100
    parent = path.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)  # commands refuse a missing one at once
        _remove_stale_parts(parent, path.name)
        if path.is_dir():
            check(given)
        tmp = Path(
            tempfile.mkdtemp(
                prefix=f".{_temp_stem(path.name)}.{os.getpid()}.",
                suffix=_temp_suffix("part"),
                dir=parent,
            )
        )
    except OSError as err:
        msg = f"{prefix}{path}: cannot create the folder ({err.strerror or err}); {hint}"
        raise InputError(msg) from None
    try:
        umask = os.umask(0)
        os.umask(umask)
        tmp.chmod(0o777 & ~umask)  # mkdtemp creates 0700; give the folder the usual mode
        token = _FOLDERS_BEING_WRITTEN.set(
            (*_FOLDERS_BEING_WRITTEN.get(()), (Path(os.path.abspath(tmp)), path))  # noqa: PTH100
        )
        try:
            yield tmp
        except Exception as err:
            full = full_disk_cause(err)
            if full is not None:
                raise disk_full_error(given, full) from None
            raise
        finally:
            _FOLDERS_BEING_WRITTEN.reset(token)
        if path.is_dir():
            check(given)
        with stop_signals_held():  # published and recorded, or neither
            _publish_folder(tmp, path)
            _PUBLISHED.append(path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
