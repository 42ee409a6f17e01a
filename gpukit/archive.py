"""The archive a kit's run brings home (gpu-kit-<label>.tar.gz, for make gpu-import): the records, the logs and the
summary, at most 16 MiB. Standard library only (it runs on the node)."""
import io
import json
import tarfile
import time

ARCHIVE_LIMIT = 15 << 20  # under the 16 MiB a file may have to come back from a lent machine


def set_aside_garbled(out, label):
    """Record lines that are not whole JSON objects (a case killed mid-write, a program's bug) are moved out of the
    record files into logs/garbled-records.txt, so that the archive's records import; the summary names them."""
    moved = []
    for f in sorted((out / "results" / label).glob("*/*.jsonl")):
        good = []
        for k, line in enumerate(f.read_text(errors="replace").splitlines(keepends=True), 1):
            try:
                ok = isinstance(json.loads(line), dict) and line.endswith("\n")
            except ValueError:
                ok = False
            (good if ok else moved).append(line if ok else f"{f.relative_to(out)}:{k}: {line.rstrip()}\n")
        if len(good) != k:
            f.write_text("".join(good))
    if moved:
        with open(out / "logs" / "garbled-records.txt", "a") as g:
            g.writelines(moved)
    return moved


def pack_archive(out, label):
    """out/gpu-kit-<label>.tar.gz: the records, the logs and the summary; logs cut to their ends if it would be
    over 16 MiB."""
    archive = out / f"gpu-kit-{label}.tar.gz"
    set_aside_garbled(out, label)
    members = [("results/" + label, out / "results" / label), ("summary.md", out / "summary.md")]
    logs = sorted((out / "logs").iterdir(), key=lambda p: p.stat().st_size)
    for cut in (None, 1 << 20, 64 << 10):
        with tarfile.open(archive, "w:gz") as t:
            for name, path in members:
                if path.exists():
                    t.add(path, arcname=name)
            for log in logs:
                if cut is None or log.stat().st_size <= cut:
                    t.add(log, arcname="logs/" + log.name)
                else:
                    data = log.read_bytes()[-cut:]
                    info = tarfile.TarInfo("logs/" + log.name)
                    info.size, info.mtime = len(data), int(time.time())
                    t.addfile(info, io.BytesIO(data))
        if archive.stat().st_size <= ARCHIVE_LIMIT:
            return archive
    return archive
