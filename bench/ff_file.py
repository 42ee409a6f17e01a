"""The form-factor file of radiosity/formfactor/file/format.hpp in Python, the one reader and writer of it outside the
C++ code: the peers of `make bench` (bench/peers.py) read the form factors with it, and the tests and the fuzz seeds
(tests/fuzz/make_ff_seeds) write files with it. It follows the documented layout, not the C++ code, so that tests
can make files the program never would (row sums above 1, NaN, broken headers) and a file the C++ reader accepts
also checks that the documentation is right.

Layout, little-endian: a 72-byte header (magic, version, resolution, n, storage, precision, mesh hash, weights,
threshold, bytes of values), n*n float32 values row-major, a uint64 FNV-1a checksum over 64-bit words of them."""
import os
import struct
from array import array

HEADER = struct.Struct("<8sIIQ8s8sQ8sdQ")
assert HEADER.size == 72
FNV_OFFSET = 1469598103934665603
FNV_PRIME = 1099511628211
MASK = (1 << 64) - 1


def fnv1a_words(data: bytes) -> int:
    """The file's checksum: FNV-1a over little-endian 64-bit words, then the trailing bytes one by one."""
    h = FNV_OFFSET
    whole = len(data) - len(data) % 8
    for (w,) in struct.iter_unpack("<Q", data[:whole]):
        h = ((h ^ w) * FNV_PRIME) & MASK
    for b in data[whole:]:
        h = ((h ^ b) * FNV_PRIME) & MASK
    return h


def mesh_hash(triangles) -> int:
    """radiosity::mesh_hash: byte-wise FNV-1a of the patch count (uint64) and every vertex (3 float64 each).
    triangles: per patch its three vertices (x, y, z)."""
    h = FNV_OFFSET
    data = struct.pack("<Q", len(triangles)) + b"".join(struct.pack("<3d", *v) for t in triangles for v in t)
    for b in data:
        h = ((h ^ b) * FNV_PRIME) & MASK
    return h


def pack(n, mesh_hash, values, resolution=256, weights=b"exact", threshold=0.0, version=1, magic=b"HPCGIFF\0",
         storage=b"dense", precision=b"float32", values_bytes=None, checksum=None) -> bytes:
    """A whole file; every field can be set wrong on purpose. values: n*n floats (stored as float32)."""
    body = array("f", values).tobytes()
    header = HEADER.pack(magic, version, resolution, n, storage, precision, mesh_hash, weights, threshold,
                         len(body) if values_bytes is None else values_bytes)
    return header + body + struct.pack("<Q", fnv1a_words(body) if checksum is None else checksum)


NAMES = ("magic", "version", "resolution", "n", "storage", "precision", "mesh_hash", "weights", "threshold",
         "values_bytes")


def header_of(data: bytes) -> dict:
    """The header fields of a file's first HEADER.size bytes, as a dict."""
    return dict(zip(NAMES, HEADER.unpack_from(data)))


def read(path):
    """(header fields as a dict, values as a list of floats) of a file written by the program."""
    data = open(path, "rb").read()
    header = header_of(data)
    values = array("f")
    values.frombytes(data[HEADER.size:HEADER.size + header["values_bytes"]])
    return header, list(values)


def rewrite(path, header, values):
    """Writes header (as read() gives it; values_bytes is recomputed) and values to path with a correct checksum."""
    fields = {k: v for k, v in header.items() if k not in ("n", "mesh_hash", "values_bytes")}
    open(path, "wb").write(pack(header["n"], header["mesh_hash"], values, **fields))


class FileError(Exception):
    """A file that is not the form factors asked for: one line saying why."""


def read_dense(path, n, want_hash):
    """The n × n float32 form factors of a file from bin/radiosity formfactors as a NumPy array, after checking its
    header against the mesh (n patches, mesh hash want_hash). Raises FileError with one line."""
    import numpy as np
    try:
        with open(path, "rb") as f:
            head = f.read(HEADER.size)
    except OSError as e:
        raise FileError(f"{path}: {e.strerror}") from None
    if len(head) < HEADER.size:
        raise FileError(f"{path}: not a form-factor file (too short)")
    h = header_of(head)
    if h["magic"] != b"HPCGIFF\0" or h["version"] != 1 or h["storage"].rstrip(b"\0") != b"dense" \
            or h["precision"].rstrip(b"\0") != b"float32":
        raise FileError(f"{path}: not a version 1 dense float32 form-factor file")
    if h["n"] != n or h["mesh_hash"] != want_hash:
        raise FileError(f"{path}: form factors of another mesh ({h['n']} patches, hash {h['mesh_hash']:#018x}; the "
                        f"solved scene has {n}, hash {want_hash:#018x})")
    if h["values_bytes"] != 4 * n * n or os.path.getsize(path) < HEADER.size + h["values_bytes"]:
        raise FileError(f"{path}: truncated form-factor file")
    return np.fromfile(path, dtype="<f4", count=n * n, offset=HEADER.size).reshape(n, n)
