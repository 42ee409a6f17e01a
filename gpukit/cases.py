"""The case lists (slurm/cases/<preset>/<experiment>.txt) as slurm/run-case reads them, for the kit's driver, which
runs their GPU cases on the node without the repository's shell harness.

A case is line k (0-based, comments and blank lines skipped) of a list, "[repeat=K] [ranks=P] PROGRAM ARGS" with the
tokens {FF_DIR}, {RRV_SCENES}, {PRESET}, {RESULTS} and {CORES} (the cores the case may use); its id is
"<preset>/<experiment>/<k>/<first 8 hex of md5(line)>", the HPCGI_CASE that run-case gives it, so the kit's records
are the same cases as the harness's. repeat=K: the case runs K times at most (a long case, fewer runs than its list's
"# repeat: N"); ranks=P: P MPI ranks (P may be {CORES})."""
import hashlib
import os
import re
from dataclasses import dataclass
from pathlib import Path

from common import backend_facts  # which backends run on a GPU: the programs' --list-backends --json
_COMMENT = re.compile(r"^\s*(#|$)")
_PREFIX = re.compile(r"^(repeat|ranks)=([1-9][0-9]*|\{CORES\})$")


def split_line(line):
    """A case line's prefixes and its command: ({"repeat": "K", "ranks": "P"} as far as given, "PROGRAM ARGS")."""
    pre, words = {}, line.split(" ")
    while words and _PREFIX.match(words[0]) and _PREFIX.match(words[0])[1] not in pre:
        m = _PREFIX.match(words.pop(0))
        pre[m[1]] = m[2]
    return pre, " ".join(words)


def cores():
    """The cores this process may run on (its affinity: a Slurm step's or a cgroup's share of the node)."""
    return len(os.sched_getaffinity(0))


@dataclass(frozen=True)
class Case:
    experiment: str
    index: int
    line: str  # as written in the list, tokens not yet replaced

    @property
    def case_id(self):
        return case_id(self.preset, self.experiment, self.index, self.line)

    preset: str = "paper"

    @property
    def prefixes(self):
        return split_line(self.line)[0]

    @property
    def command(self):
        """The line without its prefixes, tokens not yet replaced."""
        return split_line(self.line)[1]

    def backend(self):
        t = self.command.split()
        return t[t.index("--backend") + 1] if "--backend" in t[:-1] else None

    def is_gpu(self):
        """A case is a GPU case when it runs a backend the programs list as one (common/backend_facts.py)."""
        return self.backend() in backend_facts.gpu_backends()

    def argv(self, tokens):
        """The command, tokens replaced; None for a case with ranks= (MPI: never a GPU case, never in the kit)."""
        if "ranks" in self.prefixes:
            return None
        return replace(self.command, tokens).split()


def replace(text, tokens):
    """The tokens of a case line replaced ({CORES}: the cores this process may use, unless `tokens` names them)."""
    for k, v in {"CORES": cores(), **tokens}.items():
        text = text.replace("{" + k + "}", str(v))
    return text


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
