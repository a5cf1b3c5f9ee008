"""A rollback journal for ``results.h5``: a killed run's file returns to its last finished step.

HDF5 rewrites its metadata in place (B-tree nodes, object headers, the superblock) in an order
of its own, so a process killed in the middle of writing a step can leave a file whose
metadata point at blocks never written, and whose earlier steps cannot be read any more. A
run's file is therefore written through :class:`JournaledFile`, an ordinary Python file
object given to h5py (HDF5 then does all its I/O through it), which keeps the classic
rollback journal of databases (``docs/results.md#killed-runs``):

* before a byte that the file held at the last commit is overwritten (or cut off by a
  truncation), its old value is appended to the journal ``results.h5.journal``; bytes
  beyond the committed end need no copy (the rollback cuts them off);
* each journal entry is written whole (one ``write``) before the results file is touched,
  and carries a CRC-32, so an entry cut short by a kill is recognized (its write to the
  results file never happened);
* :meth:`JournaledFile.commit`, after HDF5 has flushed a finished step, deletes the
  journal: that one ``unlink`` is the instant the step becomes permanent.

After a kill, the journal holds the old contents of every committed byte the step in flight
changed: :func:`recover` writes them back (last entry first, so the oldest value of a byte
wins), cuts the file to its committed length and deletes the journal, which leaves the file
exactly, byte for byte, as it was at the last commit. Recovering again after a kill during
a recovery gives the same file. :class:`RolledBack` reads that state without changing
anything (a ``thinfilm info`` of a killed run, the checks of a resume made before the file
is opened for writing).

A journal names the device and inode of its file: one left beside a file that has since been
replaced (a new run made in the directory) is ignored, and deleted by :func:`recover`. So a
killed run's directory keeps its journal's use when moved (``mv`` keeps the inode), not when
copied: copy it after resuming it.

The guarantee is against the process dying at any instant (``kill -9``, an out-of-memory
kill, a crash), whose writes the operating system keeps; it is not one against the machine
losing power (no ``fsync`` per step).

For the tests, which place kills at the write instants (``tests/core/test_kills.py``):
:func:`kill_at_event` (or the environment variable ``THINFILM_KILL_AT_WRITE=N``) makes the
process kill itself with SIGKILL at its N-th I/O event on a journaled file (a journal entry, a
write or a truncation of the results file, a commit; a write is cut in the middle first);
:func:`io_events` counts them. Unset, a step pays one integer comparison per event.
"""

from __future__ import annotations

import fcntl
import io
import os
import signal
import struct
import zlib
from pathlib import Path

__all__ = ["JournaledFile", "RolledBack", "journal_path", "recover", "read_journal", "JournalError",
           "kill_at_event", "io_events"]

#: The journal's header: its magic, the committed length of the results file, the file's
#: device and inode (a journal applies to the file it was written for, not to one put in its
#: place), and the header's CRC-32.
MAGIC = b"TFJRNL01"
_HEADER = struct.Struct("<8sQQQI")
#: An entry: offset and length of the old bytes, then the bytes, then the CRC-32 of all that.
_ENTRY = struct.Struct("<QQ")
_CRC = struct.Struct("<I")

_KILL_AT = int(os.environ.get("THINFILM_KILL_AT_WRITE", "0") or 0)
_events = 0


class JournalError(OSError):
    """A results file that another process is writing (it holds the file's lock)."""


def journal_path(path):
    """The journal of results file ``path``: ``results.h5.journal`` beside it."""
    path = Path(path)
    return path.with_name(path.name + ".journal")


def kill_at_event(n):
    """Tests only: kill this process with SIGKILL at its ``n``-th I/O event on a journaled
    file, counted from its start (0: never)."""
    global _KILL_AT
    _KILL_AT = int(n)


def io_events():
    """The I/O events on journaled files so far in this process (the range of
    :func:`kill_at_event`)."""
    return _events


def _event(half=None):
    """Count an I/O event; at the one :func:`kill_at_event` names, die as ``kill -9`` would
    (``half()`` first writes half a buffer: a write cut in the middle)."""
    global _events
    _events += 1
    if _events == _KILL_AT:
        if half is not None:
            half()
        os.kill(os.getpid(), signal.SIGKILL)


def _write_all(fd, data, offset=None):
    view = memoryview(data).cast("B")
    while view.nbytes:
        n = os.write(fd, view) if offset is None else os.pwrite(fd, view, offset)
        view = view[n:]
        if offset is not None:
            offset += n


def read_journal(path):
    """The committed length and the valid entries of the journal of ``path``.

    Returns
    -------
    (int, list of (int, bytes)) or None
        None when there is no journal, only a header cut short (the results file was not
        touched after it), or the journal of another file (one since replaced by a new
        ``results.h5``). The entries stop at the first one cut short or corrupt: the write
        it was to precede never happened.
    """
    journal = journal_path(path)
    try:
        data = journal.read_bytes()
        stat = os.stat(path)
    except FileNotFoundError:
        return None
    if len(data) < _HEADER.size:
        return None
    magic, committed, device, inode, crc = _HEADER.unpack_from(data)
    if magic != MAGIC or zlib.crc32(data[: _HEADER.size - _CRC.size]) != crc:
        return None
    if (device, inode) != (stat.st_dev, stat.st_ino):
        return None
    entries, at = [], _HEADER.size
    while at + _ENTRY.size + _CRC.size <= len(data):
        offset, length = _ENTRY.unpack_from(data, at)
        end = at + _ENTRY.size + length
        if end + _CRC.size > len(data) or zlib.crc32(data[at:end]) != _CRC.unpack_from(data, end)[0]:
            break
        entries.append((offset, data[at + _ENTRY.size: end]))
        at = end + _CRC.size
    return committed, entries


def recover(path):
    """Roll ``path`` back to its last commit if a killed writer left a journal; returns
    whether there was one. Only for a file no process is writing."""
    journal = journal_path(path)
    if not journal.exists():
        return False
    found = read_journal(path)
    if found is not None:
        committed, entries = found
        fd = os.open(path, os.O_RDWR)
        try:
            for offset, old in reversed(entries):  # the oldest value of a byte is written last
                _write_all(fd, old, offset)
            os.ftruncate(fd, committed)
            os.fsync(fd)
        finally:
            os.close(fd)
    journal.unlink()
    return True


class _Intervals:
    """The byte ranges already saved in the journal since the last commit (sorted, disjoint)."""

    def __init__(self):
        self.ranges = []

    def missing(self, start, end):
        """The parts of ``[start, end)`` not saved yet."""
        out = []
        for a, b in self.ranges:
            if b <= start:
                continue
            if a >= end:
                break
            if a > start:
                out.append((start, a))
            start = max(start, b)
            if start >= end:
                break
        if start < end:
            out.append((start, end))
        return out

    def add(self, start, end):
        merged = []
        for a, b in sorted(self.ranges + [(start, end)]):
            if merged and a <= merged[-1][1]:
                merged[-1] = (merged[-1][0], max(merged[-1][1], b))
            else:
                merged.append((a, b))
        self.ranges = merged


class _Cursor(io.RawIOBase):
    """The position of a file object HDF5 reads through (``pos``) over a file of ``size``
    bytes: what :class:`JournaledFile` and :class:`RolledBack` share."""

    pos = 0
    size = 0

    def readable(self):
        return True

    def seekable(self):
        return True

    def seek(self, offset, whence=os.SEEK_SET):
        self.pos = {os.SEEK_SET: 0, os.SEEK_CUR: self.pos, os.SEEK_END: self.size}[whence] + offset
        return self.pos

    def tell(self):
        return self.pos


class JournaledFile(_Cursor):
    """An existing results file opened for reading and writing through a rollback journal.

    Rolls back a step a killed writer left (:func:`recover`) and takes an exclusive lock on
    the file (a second writer gets :class:`JournalError`; HDF5's readers see the lock as they
    see HDF5's own). Give it to ``h5py.File(journaled, "r+")``; call :meth:`commit` after each
    ``flush`` of a finished step.

    Parameters
    ----------
    path : str or Path

    Attributes
    ----------
    failed : bool
        Set when a write or a truncation failed (or by the caller, to abandon the changes
        since the last commit): nothing is committed any more.
    """

    def __init__(self, path):
        super().__init__()
        self.path = Path(path)
        self.journal = journal_path(self.path)
        self.fd = os.open(self.path, os.O_RDWR)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(self.fd)
            raise JournalError(f"{self.path} is being written by another process") from None
        recover(self.path)
        self.pos = 0
        self.size = os.fstat(self.fd).st_size
        self.committed = self.size
        self.jfd = None
        self.saved = _Intervals()
        self.failed = False

    # -- the journal --------------------------------------------------------------------------
    def _begin(self):
        """Start the journal of the changes since the last commit (before the first one)."""
        if self.jfd is not None:
            return
        stat = os.fstat(self.fd)
        head = MAGIC + struct.pack("<QQQ", self.committed, stat.st_dev, stat.st_ino)
        header = head + _CRC.pack(zlib.crc32(head))
        self.jfd = os.open(self.journal, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        _event(lambda: os.write(self.jfd, header[: len(header) // 2]))
        _write_all(self.jfd, header)

    def _save(self, start, end):
        """Append the committed bytes of ``[start, end)`` not saved yet to the journal."""
        self._begin()
        end = min(end, self.committed)
        if start >= end:
            return
        for a, b in self.saved.missing(start, end):
            old = os.pread(self.fd, b - a, a)
            entry = _ENTRY.pack(a, len(old)) + old
            entry += _CRC.pack(zlib.crc32(entry))
            _event(lambda: os.write(self.jfd, entry[: len(entry) // 2]))
            _write_all(self.jfd, entry)
            self.saved.add(a, b)

    def commit(self):
        """The file as it stands (flushed by HDF5) is the new state a rollback returns to.

        Nothing is committed once a write or a truncation has failed (a full disk, an
        exception raised in the middle of one): the journal stays, and the next opening
        returns the file to its last commit."""
        if self.jfd is None or self.failed:
            return
        _event()
        os.close(self.jfd)
        self.jfd = None
        os.unlink(self.journal)
        self.committed = self.size
        self.saved = _Intervals()

    # -- the file object HDF5 uses -----------------------------------------------------------
    def writable(self):
        return True

    def read(self, n=-1):
        if n is None or n < 0:
            n = max(self.size - self.pos, 0)
        data = os.pread(self.fd, n, self.pos)
        self.pos += len(data)
        return data

    def readinto(self, buffer):
        data = self.read(len(memoryview(buffer).cast("B")))
        memoryview(buffer).cast("B")[: len(data)] = data
        return len(data)

    def write(self, data):
        view = memoryview(data).cast("B")
        n = view.nbytes
        try:
            self._save(self.pos, self.pos + n)
            _event(lambda: os.pwrite(self.fd, view[: n // 2], self.pos))
            _write_all(self.fd, view, self.pos)
        except BaseException:
            self.failed = True
            raise
        self.pos += n
        self.size = max(self.size, self.pos)
        return n

    def truncate(self, size=None):
        size = self.pos if size is None else size
        if size != self.size:
            try:
                self._save(size, self.size)
                _event()
                os.ftruncate(self.fd, size)
            except BaseException:
                self.failed = True
                raise
            self.size = size
        return size

    def flush(self):
        pass

    def __repr__(self):
        return str(self.path)  # h5py's File.filename

    def close(self):
        """Close the file; an uncommitted journal stays (the next opening rolls it back)."""
        if not self.closed:
            if self.jfd is not None:
                os.close(self.jfd)
                self.jfd = None
            os.close(self.fd)
        super().close()


class RolledBack(_Cursor):
    """A results file as it was at its last commit, read-only, the file left untouched.

    Where a killed (or a running) writer left a journal, reads are patched with the
    journal's old bytes and end at the committed length. Give it to ``h5py.File(obj, "r")``.

    Parameters
    ----------
    path : str or Path
    """

    def __init__(self, path):
        super().__init__()
        self.path = Path(path)
        found = read_journal(self.path)
        self.fd = os.open(self.path, os.O_RDONLY)
        if found is None:
            self.size, self.entries = os.fstat(self.fd).st_size, []
        else:
            self.size, self.entries = found
        self.pos = 0

    def read(self, n=-1):
        end = self.size if n is None or n < 0 else min(self.pos + n, self.size)
        if end <= self.pos:
            return b""
        data = bytearray(os.pread(self.fd, end - self.pos, self.pos))
        data.extend(bytes(end - self.pos - len(data)))
        for offset, old in reversed(self.entries):
            a, b = max(offset, self.pos), min(offset + len(old), end)
            if a < b:
                data[a - self.pos: b - self.pos] = old[a - offset: b - offset]
        self.pos = end
        return bytes(data)

    def readinto(self, buffer):
        data = self.read(len(memoryview(buffer).cast("B")))
        memoryview(buffer).cast("B")[: len(data)] = data
        return len(data)

    def __repr__(self):
        return str(self.path)  # h5py's File.filename

    def close(self):
        if not self.closed:
            os.close(self.fd)
        super().close()
