#!/usr/bin/env python3
"""make gpu-import ARCHIVE=FILE: the records of a GPU kit's archive (gpu-kit/run) into results/<label>/, the label
being the GPU node's own (its results/<label>/machine.json).

    gpukit/import_archive.py ARCHIVE [--results results]

Everything is checked before anything is written: the archive must read to its end (a truncated or damaged one is
refused), hold one machine's records, every record whole (one JSON object of schema hpcgi-record/1 per line,
ending in a newline) and carrying the GPU it ran on (backend_info.gpu). Record files are append-only: a record
already there is not written twice, and no existing byte is changed; an existing machine.json is kept. Exit
status 0 when imported; 2 with one line when refused (nothing written)."""
import argparse
import json
import sys
import tarfile
import zlib
from pathlib import Path, PurePosixPath

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from common import machine_label  # noqa: E402

SCHEMA = "hpcgi-record/1"


class Refused(Exception):
    pass


def read_archive(path):
    """{member name: bytes} of every file, read to the end (so truncation is found here)."""
    files = {}
    try:
        with tarfile.open(path, "r:gz") as t:
            for m in t:
                name = PurePosixPath(m.name)
                if name.is_absolute() or ".." in name.parts:
                    raise Refused(f"{path}: member {m.name!r} points outside the archive's folder")
                if m.isfile():
                    files[str(name)] = t.extractfile(m).read()
    except (tarfile.TarError, EOFError, zlib.error, OSError) as e:
        raise Refused(f"{path} is truncated or damaged ({type(e).__name__}: {e}): nothing imported")
    return files


def check(files, path):
    """(label, machine.json bytes, {relative records path: [lines]})."""
    labels = {PurePosixPath(n).parts[1] for n in files if n.startswith("results/") and len(PurePosixPath(n).parts) > 2}
    if len(labels) != 1:
        raise Refused(f"{path} holds the records of {len(labels)} machines ({', '.join(sorted(labels)) or 'none'}); "
                      f"a kit's archive holds one")
    label = labels.pop()
    try:
        machine_label.check(label)
    except ValueError as e:
        raise Refused(f"{path}: {e}")
    machine = files.get(f"results/{label}/machine.json")
    if machine is None:
        raise Refused(f"{path} has no results/{label}/machine.json (the GPU node's description)")
    try:
        if not json.loads(machine).get("gpu"):
            raise Refused(f"{path}: results/{label}/machine.json names no GPU: these are no GPU node's records")
    except ValueError as e:
        raise Refused(f"{path}: results/{label}/machine.json is no JSON ({e})")
    records = {}
    for name, data in sorted(files.items()):
        p = PurePosixPath(name)
        if not name.startswith(f"results/{label}/") or p.suffix != ".jsonl":
            continue
        if len(p.parts) != 4:
            raise Refused(f"{path}: {name} is not results/<label>/<experiment>/<preset>.jsonl")
        text = data.decode("utf-8", errors="replace")
        if text and not text.endswith("\n"):
            raise Refused(f"{path}: {name} ends in half a record (no final newline)")
        lines = text.splitlines()
        for k, line in enumerate(lines, 1):
            try:
                rec = json.loads(line)
            except ValueError:
                raise Refused(f"{path}: {name}:{k} is not a whole record (no JSON object)")
            if not isinstance(rec, dict) or rec.get("schema") != SCHEMA:
                raise Refused(f"{path}: {name}:{k} is no {SCHEMA} record")
            if not (rec.get("backend_info") or {}).get("gpu"):
                raise Refused(f"{path}: {name}:{k} carries no GPU (backend_info.gpu): not a GPU run, nothing imported")
        records[str(PurePosixPath(*p.parts[1:]))] = lines
    if not records:
        raise Refused(f"{path} holds no records")
    return label, machine, records


def import_archive(path, results):
    label, machine, records = check(read_archive(path), path)
    results = Path(results)
    added = kept = 0
    for rel, lines in records.items():
        target = results / rel
        old = set(target.read_text().splitlines()) if target.exists() else set()
        new = [l for l in lines if l not in old]
        kept += len(lines) - len(new)
        if new:
            target.parent.mkdir(parents=True, exist_ok=True)
            with open(target, "a") as f:  # append-only: existing bytes are never touched
                f.write("".join(l + "\n" for l in new))
            added += len(new)
    mj = results / label / "machine.json"
    note = ""
    if not mj.exists():
        mj.write_bytes(machine)
    elif mj.read_bytes() != machine:
        note = f"; {mj} kept as it was (this archive's description differs)"
    print(f"gpu-import: {added} records into {results / label}/ ({len(records)} files; {kept} already there){note}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("archive", help="a gpu-kit-<label>.tar.gz made by gpu-kit/run")
    ap.add_argument("--results", default="results", help="the results folder (default results)")
    a = ap.parse_args()
    if not Path(a.archive).is_file():
        print(f"gpu-import: {a.archive}: no such file", file=sys.stderr)
        sys.exit(2)
    try:
        import_archive(a.archive, a.results)
    except Refused as e:
        print(f"gpu-import: {e}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
