"""The case lists (slurm/cases/<preset>/<experiment>.txt) as slurm/run-case reads them, for the kit's driver, which
runs their GPU cases on the node without the repository's shell harness.

A case is line k (0-based, comments and blank lines skipped) of a list, "[ranks=P] PROGRAM ARGS" with the tokens
{FF_DIR}, {RRV_SCENES}, {PRESET} and {RESULTS}; its id is "<preset>/<experiment>/<k>/<first 8 hex of md5(line)>",
the HPCGI_CASE that run-case gives it, so the kit's records are the same cases as the harness's."""
import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

from common import backend_facts  # which backends run on a GPU: the programs' --list-backends --json
_COMMENT = re.compile(r"^\s*(#|$)")


@dataclass(frozen=True)
class Case:
    experiment: str
    index: int
    line: str  # as written in the list, tokens not yet replaced

    @property
    def case_id(self):
        return case_id(self.preset, self.experiment, self.index, self.line)

    preset: str = "paper"

    def backend(self):
        t = self.line.split()
        return t[t.index("--backend") + 1] if "--backend" in t[:-1] else None

    def is_gpu(self):
        """A case is a GPU case when it runs a backend the programs list as one (common/backend_facts.py)."""
        return self.backend() in backend_facts.gpu_backends()

    def argv(self, tokens):
        """The command, tokens replaced; None for a case with ranks= (MPI: never a GPU case, never in the kit)."""
        line = self.line
        for k, v in tokens.items():
            line = line.replace("{" + k + "}", str(v))
        return None if line.startswith("ranks=") else line.split()


def case_id(preset, experiment, index, line):
    return f"{preset}/{experiment}/{index}/{hashlib.md5(line.encode()).hexdigest()[:8]}"


def read(path, preset="paper"):
    """Every case of one list."""
    path = Path(path)
    lines = [l.rstrip("\n") for l in path.read_text().splitlines() if not _COMMENT.match(l)]
    return [Case(path.stem, k, l, preset) for k, l in enumerate(lines)]


def gpu_cases(folder, preset="paper"):
    """The GPU cases of every list in `folder`, by experiment name, then index."""
    out = []
    for f in sorted(Path(folder).glob("*.txt")):
        out += [c for c in read(f, preset) if c.is_gpu()]
    return out
