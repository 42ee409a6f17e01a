#!/usr/bin/env python3
"""The harness's files, opened one way (issue 48): machine.json, the machine-id file, the records and state files
(JSON Lines), the runner's .skipped notes. Standard library only: the runner, the GPU kit and the analysis use it.

- A harness file is a regular file or nothing: opened with O_NOFOLLOW and O_NONBLOCK, a FIFO, a device, a folder or
  a symbolic link is refused with one line (HarnessFileError), never waited on, read without end or written through;
  a read is held to a size limit.
- An append is whole or absent: under an exclusive lock, a torn last line left by a killed write is cut off first
  (said on stderr), every byte is written (else the file is cut back to where it was and the error says why: a full
  disk), and the file is synced. common/record.cpp appends records the same way.
- A reader of JSON Lines names the file and line of each line that is no JSON object and goes on without it
  (read_objects returns them apart, to be counted).

    common/harness_io.py append FILE      appends the line on standard input (one line) to FILE
Exit status 0, or 2 with one line when refused."""
import errno
import fcntl
import json
import os
import stat
import sys

SMALL = 1 << 20  # machine.json, the id file
LARGE = 4 << 30  # a records or state file


class HarnessFileError(ValueError):
    """A harness file that cannot be used as one: one line saying which and why."""


def _open(path, flags, mode=0o644):
    try:
        fd = os.open(path, flags | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC, mode)
    except OSError as e:
        if e.errno == errno.ELOOP:
            raise HarnessFileError(f"{path} is a symbolic link: refused (a harness file is a regular file)") from None
        if e.errno in (errno.EISDIR, errno.ENXIO):
            raise HarnessFileError(f"{path} is no regular file: refused") from None
        raise
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        what = "a FIFO" if stat.S_ISFIFO(st.st_mode) else "a device" if stat.S_ISCHR(st.st_mode) or \
            stat.S_ISBLK(st.st_mode) else "a folder" if stat.S_ISDIR(st.st_mode) else "a socket"
        raise HarnessFileError(f"{path} is {what}, no regular file: refused")
    return fd


def read_bytes(path, limit=SMALL):
    """The bytes of a harness file, or None where there is none; HarnessFileError where it is no regular file or
    larger than `limit`."""
    try:
        fd = _open(path, os.O_RDONLY)
    except FileNotFoundError:
        return None
    try:
        size = os.fstat(fd).st_size
        if size > limit:
            raise HarnessFileError(f"{path} is {size} bytes, over the {limit} a harness file of its kind may be")
        chunks, got = [], 0
        while True:
            b = os.read(fd, min(1 << 20, limit + 1 - got))
            if not b:
                break
            chunks.append(b)
            got += len(b)
            if got > limit:
                raise HarnessFileError(f"{path} grew past {limit} bytes while read: refused")
        return b"".join(chunks)
    finally:
        os.close(fd)


def read_objects(path, limit=LARGE):
    """([(line number, JSON object)], [(line number, why)]) of a JSON Lines file ([], [] where there is none)."""
    data = read_bytes(path, limit)
    good, bad = [], []
    for n, raw in enumerate((data or b"").split(b"\n"), 1):
        if not raw.strip():
            continue
        try:
            obj = json.loads(raw.decode("utf-8"))
        except (ValueError, UnicodeDecodeError, RecursionError) as e:
            bad.append((n, f"not JSON ({str(e)[:60]})"))
            continue
        (good if isinstance(obj, dict) else bad).append((n, obj) if isinstance(obj, dict) else
                                                        (n, f"a JSON {type(obj).__name__}, no object"))
    return good, bad


def _after_last_newline(fd, size):
    end = size
    while end > 0:
        start = max(0, end - 65536)
        chunk = os.pread(fd, end - start, start)
        k = chunk.rfind(b"\n")
        if k >= 0:
            return start + k + 1
        end = start
    return 0


def append_line(path, line):
    """Appends `line` (no newline in it) and a newline to the harness file `path`, made if missing: whole or not at
    all (see above). Raises HarnessFileError with one line on any failure."""
    if "\n" in line or "\r" in line:
        raise HarnessFileError(f"{path}: a line to append holds a line break")
    data = (line + "\n").encode()
    try:
        fd = _open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT)
    except OSError as e:
        raise HarnessFileError(f"cannot open {path}: {e.strerror}") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        old = os.fstat(fd).st_size
        if old and os.pread(fd, 1, old - 1) != b"\n":
            keep = _after_last_newline(fd, old)
            os.ftruncate(fd, keep)
            print(f"harness: {path} ended in a torn line of {old - keep} bytes (a write that was killed): cut off "
                  f"before appending", file=sys.stderr)
            old = keep
        view = memoryview(data)
        try:
            while view:
                n = os.write(fd, view)
                if n <= 0:
                    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
                view = view[n:]
            os.fsync(fd)
        except OSError as e:
            os.ftruncate(fd, old)
            raise HarnessFileError(f"cannot append to {path}: {e.strerror} (nothing of the line was kept)") from None
    except OSError as e:
        raise HarnessFileError(f"cannot append to {path}: {e.strerror}") from None
    finally:
        os.close(fd)


def main(argv):
    if len(argv) != 2 or argv[0] != "append":
        print("usage: common/harness_io.py append FILE   (the line on standard input)", file=sys.stderr)
        return 2
    line = sys.stdin.read(SMALL + 1)
    if len(line) > SMALL:
        print(f"harness_io: the line for {argv[1]} is over {SMALL} bytes", file=sys.stderr)
        return 2
    try:
        append_line(argv[1], line.rstrip("\n"))
    except HarnessFileError as e:
        print(f"harness_io: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
