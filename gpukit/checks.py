"""What a run of the kit must show to pass: the checks of its steps, each returning None when it passed, else why
not. Standard library only (it runs on the GPU node)."""

# The bound of --check-symmetry on the multigrid V-cycle in double, as the CPU's tests hold it
# (tests/integration/test_poisson.py, tests/unit/poisson/test_mg.cpp).
MG_ASYMMETRY_BOUND = 1e-12


def converged_and_agreed(rec):
    """A radiosity record counts when it converged (or ran its fixed steps) and agreed with float64."""
    r, v = rec.get("result", {}), rec.get("verify") or {}
    if r.get("status") not in ("converged", "steps_done"):
        return f"status {r.get('status')} ({r.get('detail', '')})"
    if v.get("agreed") is not True:
        return f"disagrees with the float64 reference (max rel diff {v.get('max_rel_diff')}, bound {v.get('bound')})"
    return None


def poisson_converged(rec):
    r = rec.get("result", {})
    if r.get("converged") is not True:
        return f"did not converge: status {r.get('status')} after {r.get('iterations')} iterations"
    return None


def mg_symmetric(rec):
    """A multigrid run with --check-symmetry: converged, and its V-cycle symmetric to rounding."""
    why = poisson_converged(rec)
    if why:
        return why
    a = rec.get("result", {}).get("mg_asymmetry")
    if a is None:
        return "no result.mg_asymmetry in the record (was --check-symmetry passed?)"
    if not a <= MG_ASYMMETRY_BOUND:
        return f"the V-cycle is not symmetric: mg_asymmetry {a:.3g} > {MG_ASYMMETRY_BOUND:g}"
    return None


def run_name(rec):
    p = rec["params"]
    name = p["backend"] + ("" if p.get("variant") in (None, "onesweep") else " " + p["variant"])
    return name + (" --precond mg" if p.get("precond") == "mg" else "")


def poisson_agree(recs):
    """The runs after the first against the first (the CPU's): iterations within 1, max |u - u_h| to 4 digits."""
    if any(r is None for r in recs):
        return "a run printed no record"
    ref, bad = recs[0]["result"], []
    for r in recs[1:]:
        name = run_name(r)
        it, e = r["result"]["iterations"], r["result"]["error_inf"]
        if abs(it - ref["iterations"]) > 1:
            bad.append(f"{name}: {it} iterations, {run_name(recs[0])} {ref['iterations']}")
        if not abs(e - ref["error_inf"]) <= 5e-4 * abs(ref["error_inf"]):
            bad.append(f"{name}: error {e:.6g}, {run_name(recs[0])} {ref['error_inf']:.6g} (not the same to 4 digits)")
    return "; ".join(bad) or None


def gpu_tests_ran(text):
    """The GPU unit tests must have run, not skipped for want of a GPU."""
    return "skipped: the GPU backends cannot run here" if "the GPU backends cannot run here" in text else None


def sanitizer_clean(text):
    """compute-sanitizer's own summary: no error (memcheck, initcheck), no hazard (racecheck)."""
    if "ERROR SUMMARY: 0 errors" in text or "RACECHECK SUMMARY: 0 hazards" in text:
        return None
    found = [l.strip("= ").strip() for l in text.splitlines() if "SUMMARY" in l]
    return "compute-sanitizer: " + ("; ".join(found) if found else "no summary line")


def sanitizer_refusal(text):
    """The line by which compute-sanitizer refuses the device itself (as under gVisor: "Device not supported", then
    error 999 at the first allocation), or None. Only the refusal of the device is a reason to skip the
    sanitizer's steps: an error it finds in a kernel is a failure."""
    for line in text.splitlines():
        if "Device not supported" in line or "device not supported" in line.lower():
            return line.strip("= ").strip()
    return None
