#!/usr/bin/python3
"""Headless DISPLAY program for LinuxCNC, written for mtwin's tests.

LinuxCNC starts it as `display.py -ini INI` once HAL is up; when it exits,
LinuxCNC shuts down. It resets e-stop, switches the machine on, homes every
joint, starts readers of the FIFOs of the `sampler` component the test's
HAL file sets up (their type strings in MTWIN_SIM_CFG, comma-separated; all
enabled together by the signal `mtwin-sample-on`; the first program's
samples begin with the servo thread, homing included), then runs
the programs of MTWIN_SIM_RUNS one after the other: a JSON list of
{"program": path, "feed": feed override, "rapid": rapid override (fractions,
default 1), "timeout": s of real time, "hal": ["setp|sets NAME VALUE", ...]}.
For program i it checks the machine stands where homing left it (the
program before must end there), sets its HAL values, enables the samplers,
runs it to its end, disables the samplers (samples<i>_<k>.txt per FIFO k),
and restores the HAL values. At the end it writes MTWIN_SIM_OUT/result.json:
{"ok", "stage", "errors", "messages", "clock", "runs": [{"messages",
"clock"}]} ("clock": wall clock notes for the test's timing print).
"""
import json
import os
import subprocess
import sys
import threading
import time

import hal
import linuxcnc

OUT = os.environ["MTWIN_SIM_OUT"]
# The programs of the session, in order (a JSON list; see the docstring).
with open(os.environ["MTWIN_SIM_RUNS"]) as _f:
    RUNS = json.load(_f)
CFGS = os.environ["MTWIN_SIM_CFG"].split(",")

result = {
    "ok": False,
    "stage": "connect",
    "errors": [],
    "messages": [],
    "clock": {},
    "runs": [],
}


def mark(what, where=None):
    """Notes the wall clock (s since the epoch) at `what`, for the test's timing print."""
    (where if where is not None else result)["clock"][what] = time.time()


mark("display")


def save():
    with open(os.path.join(OUT, "result.json.tmp"), "w") as f:
        json.dump(result, f)
    os.replace(os.path.join(OUT, "result.json.tmp"), os.path.join(OUT, "result.json"))


ERROR_KINDS = (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR)


class Failed(Exception):
    pass


_COMP = []


class Reader:
    """Reads sampler FIFO `k` (type string `cfg`) into a file per program."""

    def __init__(self, k, cfg):
        if not _COMP:
            comp = hal.component("mtwin_reader")
            comp.ready()
            _COMP.append(comp)
        self.stream = hal.stream(_COMP[0], hal.sampler_base + k, cfg)
        self.k = k

    def start(self, i):
        """Starts writing what the FIFO holds to samples<i>_<k>.txt."""
        self.path = os.path.join(OUT, "samples%d_%d.txt" % (i, self.k))
        self.overruns = self.stream.num_overruns
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        n = 0
        with open(self.path, "w") as f:
            while True:
                v = self.stream.read()
                if not v:
                    if self.stop.is_set():
                        break
                    time.sleep(0.002)
                    continue
                # Bits as 0 and 1, numbers as Python prints them.
                f.write("%d %s\n" % (n, " ".join(repr(int(x) if isinstance(x, bool) else x) for x in v)))
                n += 1
            if self.stream.num_overruns != self.overruns:
                f.write("overrun\n")

    def finish(self):
        # Let the reader empty the FIFO, then stop it.
        t0 = time.time()
        while self.stream.depth > 0 and time.time() - t0 < 120:
            time.sleep(0.01)
        self.stop.set()
        self.thread.join()


def halcmd(*args):
    subprocess.run(["halcmd"] + list(args), check=True)


def main():
    s = linuxcnc.stat()
    c = linuxcnc.command()
    e = linuxcnc.error_channel()
    messages = [result["messages"]]

    def drain():
        while True:
            m = e.poll()
            if not m:
                return
            kind, text = m
            if kind in ERROR_KINDS:
                result["errors"].append(text)
            else:
                messages[0].append(text)

    def wait(cond, what, seconds):
        t0 = time.time()
        while True:
            s.poll()
            drain()
            if result["errors"]:
                raise Failed("error while waiting for " + what)
            if cond():
                return
            if time.time() - t0 > seconds:
                raise Failed("timed out after %g s waiting for %s" % (seconds, what))
            time.sleep(0.005)

    result["stage"] = "estop reset"
    c.state(linuxcnc.STATE_ESTOP_RESET)
    wait(lambda: s.task_state == linuxcnc.STATE_ESTOP_RESET, "e-stop reset", 30)
    result["stage"] = "machine on"
    c.state(linuxcnc.STATE_ON)
    wait(lambda: s.task_state == linuxcnc.STATE_ON, "machine on", 30)
    result["stage"] = "home"
    c.mode(linuxcnc.MODE_MANUAL)
    c.wait_complete()
    c.home(-1)
    wait(lambda: all(s.homed[i] for i in range(s.joints)), "homing", 60)
    mark("homed")
    c.mode(linuxcnc.MODE_AUTO)
    c.wait_complete()
    s.poll()
    # Where homing left the machine: every program starts there.
    start = (s.position, s.joint_position, s.tool_in_spindle)
    result["stage"] = "sampler"
    samplers = [Reader(k, cfg) for k, cfg in enumerate(CFGS)]
    for i, r in enumerate(RUNS):
        run = {"messages": [], "clock": {}}
        result["runs"].append(run)
        messages[0] = run["messages"]
        result["stage"] = "program %d: open" % i
        s.poll()
        now = (s.position, s.joint_position, s.tool_in_spindle)
        # Within 1e-9 (mm, deg): a move ends within rounding of its end
        # point, and LinuxCNC drops moves shorter than that.
        if i > 0 and (
            now[2] != start[2]
            or any(abs(a - b) > 1e-9 for k in (0, 1) for a, b in zip(now[k], start[k]))
        ):
            raise Failed(
                "program %d would not start where homing left the machine: "
                "(position, joints, tool) %r, not %r "
                "(the program before it must end there)" % (i, now, start)
            )
        c.program_open(r["program"])
        c.wait_complete()
        wait(lambda: True, "open", 5)
        if i == 0:
            # The HAL pins and parameters as they are now, for diagnosis.
            # (Here, after opening the first program, as when every
            # program ran alone: LinuxCNC's I/O controller acts every
            # 100 ms, [EMCIO] CYCLE_TIME, and the coolant test's waits
            # depend on where that cycle stands when the program starts.)
            with open(os.path.join(OUT, "hal.txt"), "w") as f:
                subprocess.run(["halcmd", "show", "all"], stdout=f, check=False)
        # This program's HAL lines (`setp`/`sets`), the values before them
        # restored once it has run.
        restore = []
        for line in r.get("hal", []):
            w = line.split()
            if len(w) != 3 or w[0] not in ("setp", "sets"):
                raise Failed("program %d: HAL line %r is not `setp|sets NAME VALUE`" % (i, line))
            restore.append([w[0], w[1], repr(hal.get_value(w[1]))])
            halcmd(*w)
        for smp in samplers:
            smp.start(i)
        try:
            halcmd("sets", "mtwin-sample-on", "1")
            result["stage"] = "program %d: run" % i
            c.feedrate(r.get("feed", 1.0))
            c.rapidrate(r.get("rapid", 1.0))
            c.wait_complete()
            mark("run", run)
            c.auto(linuxcnc.AUTO_RUN, 0)
            wait(lambda: s.interp_state != linuxcnc.INTERP_IDLE, "the program to start", 10)
            wait(
                lambda: s.interp_state == linuxcnc.INTERP_IDLE and s.queue == 0 and s.inpos,
                "the program to end",
                r.get("timeout", 600),
            )
            mark("end", run)
            # A few idle periods after the end, then stop sampling.
            time.sleep(0.05)
            halcmd("sets", "mtwin-sample-on", "0")
        finally:
            for smp in samplers:
                smp.finish()
        for w in restore:
            halcmd(*w)
        mark("drained", run)
    messages[0] = result["messages"]
    result["stage"] = "done"
    result["ok"] = True


try:
    main()
except Exception as ex:  # reported to the test through result.json
    result["errors"].append("%s: %s" % (type(ex).__name__, ex))
save()
sys.exit(0 if result["ok"] else 1)
