"""The GPU's state beside each timed run of the kit: its clocks, temperature, power and the reasons NVML gives for
holding its clocks down, read through NVML (libnvidia-ml.so.1, which the NVIDIA driver installs beside libcuda.so.1)
by ctypes in microseconds, so that every run gets a sample before and after it. Standard library only (it runs on
the node).

A run is disturbed when, before or after it, the GPU was held down by something other than the work itself: a
hardware slowdown, thermal slowdown (software or hardware) or the power brake (NVML's clock event reasons
0x8, 0x20, 0x40, 0x80). The software power cap (0x4) is how a loaded GPU normally runs: it is recorded, not
flagged."""
import ctypes
import os
import time

REASONS = {0x1: "idle", 0x2: "applications clocks", 0x4: "sw power cap", 0x8: "hw slowdown", 0x10: "sync boost",
           0x20: "sw thermal slowdown", 0x40: "hw thermal slowdown", 0x80: "hw power brake",
           0x100: "display clock"}
DISTURBING = 0x8 | 0x20 | 0x40 | 0x80
_CLOCK_SM, _CLOCK_MEM, _TEMPERATURE_GPU = 1, 2, 0


class Nvml:
    """One GPU's NVML handle, opened once (`Nvml.open()` returns None with the reason in Nvml.why where NVML cannot
    be loaded or has no device)."""
    why = None

    def __init__(self, lib, handle, index):
        self.lib, self.handle, self.index = lib, handle, index

    @classmethod
    def open(cls, index=None):
        index = int(os.environ.get("CUDA_VISIBLE_DEVICES", "0").split(",")[0] or 0) if index is None else index
        try:
            lib = ctypes.CDLL("libnvidia-ml.so.1")
        except OSError as e:
            cls.why = f"libnvidia-ml.so.1 cannot be loaded ({e})"
            return None
        init = getattr(lib, "nvmlInit_v2", None) or getattr(lib, "nvmlInit", None)
        get = getattr(lib, "nvmlDeviceGetHandleByIndex_v2", None) or getattr(lib, "nvmlDeviceGetHandleByIndex", None)
        if init is None or get is None:
            cls.why = "libnvidia-ml.so.1 has no nvmlInit or nvmlDeviceGetHandleByIndex"
            return None
        rc = init()
        if rc != 0:
            cls.why = f"nvmlInit failed with {rc}"
            return None
        handle = ctypes.c_void_p()
        rc = get(ctypes.c_uint(index), ctypes.byref(handle))
        if rc != 0:
            cls.why = f"nvmlDeviceGetHandleByIndex({index}) failed with {rc}"
            return None
        return cls(lib, handle, index)

    def _uint(self, fn, *args):
        f = getattr(self.lib, fn, None)
        if f is None:
            return None
        v = ctypes.c_uint(0)
        return v.value if f(self.handle, *args, ctypes.byref(v)) == 0 else None

    def reasons(self):
        for name in ("nvmlDeviceGetCurrentClocksEventReasons", "nvmlDeviceGetCurrentClocksThrottleReasons"):
            f = getattr(self.lib, name, None)
            if f is not None:
                v = ctypes.c_ulonglong(0)
                return v.value if f(self.handle, ctypes.byref(v)) == 0 else None
        return None

    def sample(self):
        """{utc, sm_MHz, mem_MHz, temperature_C, power_W, reasons (bits), reasons_text}; a field NVML does not
        answer is None."""
        power = self._uint("nvmlDeviceGetPowerUsage")
        bits = self.reasons()
        return {"utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                "sm_MHz": self._uint("nvmlDeviceGetClockInfo", ctypes.c_int(_CLOCK_SM)),
                "mem_MHz": self._uint("nvmlDeviceGetClockInfo", ctypes.c_int(_CLOCK_MEM)),
                "temperature_C": self._uint("nvmlDeviceGetTemperature", ctypes.c_int(_TEMPERATURE_GPU)),
                "power_W": None if power is None else power / 1000.0,
                "reasons": bits, "reasons_text": describe(bits)}


def show(sample):
    """One sample in words."""
    if not sample or "error" in sample:
        return f"no sample ({(sample or {}).get('error', 'NVML not open')})"
    val = lambda k, unit: "?" if sample.get(k) is None else f"{sample[k]:.0f} {unit}"
    return (f"SM {val('sm_MHz', 'MHz')}, memory {val('mem_MHz', 'MHz')}, {val('temperature_C', 'C')}, "
            f"{val('power_W', 'W')}, clock reasons: {sample.get('reasons_text')}")


def describe(bits):
    if bits is None:
        return None
    return ", ".join(v for k, v in REASONS.items() if bits & k) or "none"


def disturbed(before, after):
    """(disturbed, reason or None) from the samples before and after a run (either may be None: no NVML)."""
    bad = [(when, s["reasons"] & DISTURBING) for when, s in (("before", before), ("after", after))
           if s and isinstance(s.get("reasons"), int) and s["reasons"] & DISTURBING]
    if not bad:
        return False, None
    return True, "; ".join(f"the GPU {when} the run: {describe(b)}" for when, b in bad)
