"""Every output of every program passes the one output check (issue 33, problems 6-9): the output options are read
from each program's --help, and each is pointed at a FIFO and at the run's own input (through a hard link: another
name of the same file); `relight --png-frames` and the scene's OBJ mesh are covered; relight refuses an infinite
frame with exit status 3; a signal ignored at the start stays ignored; a huge frames file is refused, not held."""
import json
import os
import re
import signal
import subprocess
import time

import pytest

from conftest import BIN, ROOT, run
from test_hostile import BOX, refused, state

# Options that take a string but name no file the run writes or reads.
NOT_FILES = {"--backend", "--view", "--size", "--stop"}
INPUTS = {"--ff", "--frames", "--reference-ff"}
# Every output option, and the file(s) it makes of VALUE (a prefix gives names), with what it needs beside it.
OUTPUTS = {
    "--record": ("{}", []),
    "--out": ("{}", []),
    "--output": ("{}", []),
    "--png": ("{}", []),
    "--snapshot-prefix": ("{}_iter1.png", ["--snapshots", "1"]),
    "--snapshots": ("snapshot_iter{}.png", []),
    "--basis": ("{}", []),
    "--png-frames": ("{}_0001.png", []),
    "--solution": ("{}", []),
}
PROGRAMS = {
    "radiosity info": ["box.xml"],
    "radiosity formfactors": ["box.xml", "--hemicube", "8", "--out", "new.ff"],
    "radiosity solve": ["box.xml", "--ff", "box.ff", "--steps", "2"],
    "radiosity relight": ["box.xml", "--ff", "box.ff", "--random-frames", "2", "--size", "8x8"],
    "radiosity web": ["box.xml", "--ff", "box.ff", "--output", "new.html"],
    "poisson": ["--n", "8"],
    "stream": ["--size", "1024", "--trials", "1"],
}


def command(program, *args):
    exe, *sub = program.split()
    return [BIN / exe, *sub, *args]


def options(program):
    """{long option name: (its type, the rest of its --help line)}."""
    out = {}
    for line in run(command(program, "--help")).stdout.splitlines():
        m = re.match(r"^  (?:-\w,)?(--[\w-]+)(.*)$", line)
        if m:
            rest = m.group(2).strip()
            out[m.group(1)] = (rest.split()[0] if rest else "", rest)
    return out


def output_options(program):
    """Options that write: a file-name option classified so here, and any whose help says it writes."""
    found = set()
    for name, (kind, text) in options(program).items():
        file_like = kind == "TEXT"  # not TEXT:{choices} nor TEXT:BYTES
        says_writes = re.search(r"\b(write|writes|written|render|append)\b", text)
        if file_like and name not in NOT_FILES | INPUTS | set(OUTPUTS):
            pytest.fail(f"{program} {name}: a file option the output check is not known to cover; classify it here")
        if name in OUTPUTS or (says_writes and name not in INPUTS):
            found.add(name)
    return found


def test_every_program_and_subcommand_is_attacked():
    """A new program in bin/ or a new subcommand of bin/radiosity fails here until its outputs are attacked below."""
    assert {p.name for p in BIN.iterdir() if os.access(p, os.X_OK)} == {p.split()[0] for p in PROGRAMS}
    help_text = run([BIN / "radiosity", "--help"]).stdout.split("Subcommands:")[1].split("\n\n")[0]
    subs = {line.split()[0] for line in help_text.strip().splitlines()}
    assert subs == {p.split()[1] for p in PROGRAMS if p.startswith("radiosity ")}, subs


def test_every_output_option_of_every_program_refuses_a_fifo_and_the_runs_input(tmp_path):
    (tmp_path / "box.xml").write_text(BOX)
    assert run(command("radiosity formfactors", tmp_path / "box.xml", "-o", tmp_path / "box.ff", "--hemicube", "8",
                       "--quiet")).returncode == 0
    tried = set()
    for program, base in PROGRAMS.items():
        for opt in sorted(output_options(program)):
            assert opt in OUTPUTS, f"{program} {opt} writes, and no attack on it is known here"
            pattern, extra = OUTPUTS[opt]
            args = [a for k, a in enumerate(base) if a != opt and (k == 0 or base[k - 1] != opt)]
            assert "--quiet" not in args
            for victim in ("fifo", "input"):
                d = tmp_path / f"{program.replace(' ', '-')}{opt}-{victim}"
                d.mkdir()
                for f in ("box.xml", "box.ff"):
                    os.link(tmp_path / f, d / f)
                value = "1" if opt == "--snapshots" else "out"
                target = d / pattern.format(value)
                if victim == "fifo":
                    os.mkfifo(target)
                else:  # another name of the scene, which every scene-reading run reads
                    if program in ("poisson", "stream"):
                        continue
                    os.link(d / "box.xml", target)
                before = state(d)
                p = run(command(program, *args, opt, value, *extra, "--quiet"), cwd=d, timeout=60)
                refused(p, target.name, "FIFO" if victim == "fifo" else "input")  # refused for that reason
                assert state(d) == before, (program, opt, victim)
                tried.add((program, opt))
    assert {o for _, o in tried} == set(OUTPUTS)  # every output option was found in some --help and attacked


@pytest.fixture
def lit(tmp_path):
    (tmp_path / "box.xml").write_text(BOX)
    p = run(command("radiosity formfactors", tmp_path / "box.xml", "-o", tmp_path / "box.ff", "--hemicube", "8",
                    "--quiet"))
    assert p.returncode == 0, p.stderr
    return tmp_path


def test_png_frames_never_replace_an_input_a_link_or_a_fifo(lit):
    d = lit
    frames = d / "f.json"
    frames.write_text(json.dumps({"frames": [{"lights": {"box.1": {"intensity": x}}} for x in (1, 0.5, 0.2)]}))
    r = ["relight", "box.xml", "--ff", "box.ff", "--frames", "f.json", "--size", "8x8", "--quiet"]
    os.symlink("box.ff", d / "pic_0002.png")  # the third frame's name leads to the form factors
    before = state(d)
    refused(run(command("radiosity", *r, "--png-frames", "pic"), cwd=d), "--png-frames", "pic_0002.png", "input")
    os.remove(d / "pic_0002.png")
    os.mkfifo(d / "pic_0001.png")
    before = state(d)
    refused(run(command("radiosity", *r, "--png-frames", "pic"), cwd=d, timeout=20), "pic_0001.png", "FIFO")
    assert state(d) == before
    os.remove(d / "pic_0001.png")
    before = state(d)
    refused(run(command("radiosity", *r, "--png-frames", "f.json"[:-5], "--basis", "f_0000.png"), cwd=d),
            "also given as")  # the basis would be frame 0's picture
    os.rename(d / "f.json", d / "fr_0000.png")  # the frames file itself is named like frame 0's picture
    r[5] = "fr_0000.png"
    before = state(d)
    refused(run(command("radiosity", *r, "--png-frames", "fr"), cwd=d), "fr_0000.png", "input")
    assert state(d) == before


def test_no_output_replaces_the_obj_mesh_the_scene_reads(tmp_path):
    (tmp_path / "teapot.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\n")
    (tmp_path / "pot.xml").write_text(
        '<scene><head><objectdef name="pot"><teapot name="pot" emission="1,1,1" reflectivity=".4,.4,.4"/>'
        '</objectdef></head><body><object name="pot"/></body></scene>')
    os.mkdir(tmp_path / "sub")
    os.link(tmp_path / "teapot.obj", tmp_path / "mesh-copy.ff")  # another name of the mesh
    before = state(tmp_path)
    refused(run(command("radiosity", "formfactors", "pot.xml", "-o", "mesh-copy.ff", "--hemicube", "8", "--quiet"),
                cwd=tmp_path), "input")
    refused(run(command("radiosity", "info", "pot.xml", "--record", "sub/../teapot.obj"), cwd=tmp_path), "input")
    assert state(tmp_path) == before
    p = run(command("radiosity", "formfactors", "pot.xml", "-o", "pot.ff", "--hemicube", "8", "--quiet"), cwd=tmp_path)
    assert p.returncode == 0, p.stderr  # the mesh is read, and another output is fine


def test_relight_refuses_a_frame_whose_radiosity_is_infinite(lit):
    d = lit
    (d / "f.json").write_text(json.dumps({"frames": [{"lights": {"box.1": {"intensity": 0.5}}},
                                                     {"lights": {"box.1": {"intensity": 1e30, "rgb": [1e30, 1, 1]}}},
                                                     {"lights": {"box.1": {"intensity": 1}}}]}))
    p = run(command("radiosity", "relight", "box.xml", "--ff", "box.ff", "--frames", "f.json", "--record", "r.jsonl",
                    "--record-patches", "2", "--quiet"), cwd=d)
    assert p.returncode == 3, (p.returncode, p.stderr)
    assert "frame 1: nonfinite: the radiosity of patch 0, channel r, is inf" in p.stderr, p.stderr
    rec = json.loads((d / "r.jsonl").read_text().splitlines()[-1])
    assert rec["result"]["exit_status"] == 3 and "frame 1: nonfinite" in rec["result"]["exit_reason"]
    per_frame = rec["result"]["per_frame"]
    assert len(per_frame) == 2 and per_frame[1]["status"] == "nonfinite" and "radiosity" not in per_frame[1]


def test_a_frames_file_is_bounded_before_it_is_held(lit):
    d = lit
    r = ["relight", "box.xml", "--ff", "box.ff", "--quiet"]
    (d / "many.json").write_text('{"frames": [' + ",".join(["{}"] * 200_001) + "]}")  # 600 kB
    refused(run(command("radiosity", *r, "--frames", "many.json"), cwd=d), "200001 frames, more than 100000")
    with open(d / "big.json", "w") as f:
        f.write('{"frames": [{}' + " " * (33 << 20) + "]}")
    refused(run(command("radiosity", *r, "--frames", "big.json"), cwd=d), "more than 32.0 MiB")
    refused(run(command("radiosity", *r, "--random-frames", "100001"), cwd=d), "--random-frames")
    # 30000 frames over 300 entities that change no reflectivity share one copy of the reflectivities (each its own
    # copy: 360 MB)
    tiles = "".join(f'<objectdef name="t{k}"><triangleset name="t" emission="0,0,0" reflectivity=".5,.5,.5"><triangle>'
                    f'<vertex x="{k}" y="0" z="0"/><vertex x="{k}" y="0" z="1"/><vertex x="{k + 1}" y="0" z="0"/>'
                    f'</triangle></triangleset></objectdef>' for k in range(300))
    lamp = BOX.split("<head>")[1].split("</head>")[0]
    body = "".join(f'<object name="t{k}"/>' for k in range(300))
    (d / "tiles.xml").write_text(f'<scene><head>{lamp}{tiles}</head><body><object name="box"/>{body}</body></scene>')
    assert run(command("radiosity", "formfactors", "tiles.xml", "-o", "tiles.ff", "--hemicube", "4", "--quiet"),
               cwd=d).returncode == 0
    peak = {}
    for n in (1, 30_000):
        (d / "ok.json").write_text('{"frames": [' + ",".join(["{}"] * n) + "]}")
        p = subprocess.run(["/usr/bin/time", "-f", "%M", str(BIN / "radiosity"), "relight", "tiles.xml", "--ff",
                            "tiles.ff", "--frames", "ok.json", "--quiet"], cwd=d, capture_output=True, text=True,
                           timeout=120)
        assert p.returncode == 0, p.stderr
        peak[n] = int(p.stderr.strip().splitlines()[-1])  # kB of resident memory at most
    assert peak[30_000] - peak[1] < 100_000, peak  # the libraries' own (CUDA's) are there for one frame too


def poisson_signalled(d, ignored, sigs):
    """bin/poisson writing a 32 MiB solution, sent `sigs` once its temporary file appears; SIGINT, SIGHUP and SIGQUIT
    ignored from its start (nohup, a script's background job) or at their default, whatever pytest inherited."""
    def dispositions():
        for s in (signal.SIGINT, signal.SIGHUP, signal.SIGQUIT):
            signal.signal(s, signal.SIG_IGN if ignored else signal.SIG_DFL)
    p = subprocess.Popen([str(BIN / "poisson"), "--n", "2048", "--steps", "1", "--solution", "u.bin", "--quiet"],
                         cwd=d, preexec_fn=dispositions, stderr=subprocess.PIPE, text=True)
    t = time.time()
    while p.poll() is None and not [f for f in os.listdir(d) if f.startswith(".hpcgi-")] and time.time() - t < 60:
        time.sleep(0.0005)
    seen = p.poll() is None
    for s in sigs:
        p.send_signal(s)
    return p.wait(timeout=60), seen, p.stderr.read()


def test_a_signal_ignored_at_the_start_stays_ignored_and_the_output_is_written(tmp_path):
    for sig in (signal.SIGINT, signal.SIGHUP):
        d = tmp_path / sig.name
        d.mkdir()
        status, seen, err = poisson_signalled(d, True, [sig, signal.SIGQUIT])
        assert seen, "the solution was written before its temporary file was seen"
        assert status == 0, err
        assert os.path.getsize(d / "u.bin") == 8 * 2048 * 2048 and os.listdir(d) == ["u.bin"]


def test_a_caught_signal_still_ends_the_run_and_leaves_nothing(tmp_path):
    status, seen, _ = poisson_signalled(tmp_path, False, [signal.SIGHUP])
    assert seen and status == -signal.SIGHUP and os.listdir(tmp_path) == []
