#!/usr/bin/python3
"""Headless DISPLAY program for LinuxCNC, written for mtwin's tests.

LinuxCNC starts it as `display.py -ini INI` once HAL is up; when it exits,
LinuxCNC shuts down. It resets e-stop, switches the machine on, homes every
joint, opens the program named by MTWIN_SIM_PROGRAM, starts
readers
of the FIFOs of the `sampler` component the test's HAL file sets up (their
type strings in MTWIN_SIM_CFG, comma-separated; all enabled together by the
signal `mtwin-sample-on`, off until now), enables the samplers, runs the program to its end, disables the sampler
and writes MTWIN_SIM_OUT/result.json: {"ok", "stage", "errors", "messages"}.
MTWIN_SIM_TIMEOUT bounds the run in seconds (real time);
MTWIN_SIM_FEED_OVERRIDE and MTWIN_SIM_RAPID_OVERRIDE (fractions, default 1)
are set before the run.
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
PROGRAM = os.environ["MTWIN_SIM_PROGRAM"]
TIMEOUT = float(os.environ.get("MTWIN_SIM_TIMEOUT", "600"))
CFGS = os.environ["MTWIN_SIM_CFG"].split(",")
# Feed and rapid overrides set before the run (fractions, 1 = none).
FEED_OVERRIDE = float(os.environ.get("MTWIN_SIM_FEED_OVERRIDE", "1"))
RAPID_OVERRIDE = float(os.environ.get("MTWIN_SIM_RAPID_OVERRIDE", "1"))

result = {"ok": False, "stage": "connect", "errors": [], "messages": []}


def save():
    with open(os.path.join(OUT, "result.json.tmp"), "w") as f:
        json.dump(result, f)
    os.replace(os.path.join(OUT, "result.json.tmp"), os.path.join(OUT, "result.json"))


ERROR_KINDS = (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR)


class Failed(Exception):
    pass


_COMP = []


class Reader:
    """Reads sampler FIFO `k` (type string `cfg`) into samplesK.txt."""

    def __init__(self, k, cfg):
        if not _COMP:
            comp = hal.component("mtwin_reader")
            comp.ready()
            _COMP.append(comp)
        self.stream = hal.stream(_COMP[0], hal.sampler_base + k, cfg)
        self.path = os.path.join(OUT, "samples%d.txt" % k)
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
                f.write("%d %s\n" % (n, " ".join(repr(x) for x in v)))
                n += 1
            if self.stream.num_overruns:
                f.write("overrun\n")

    def finish(self):
        # Let the reader empty the FIFO, then stop it.
        t0 = time.time()
        while self.stream.depth > 0 and time.time() - t0 < 120:
            time.sleep(0.01)
        self.stop.set()
        self.thread.join()


def main():
    s = linuxcnc.stat()
    c = linuxcnc.command()
    e = linuxcnc.error_channel()

    def drain():
        while True:
            m = e.poll()
            if not m:
                return
            kind, text = m
            if kind in ERROR_KINDS:
                result["errors"].append(text)
            else:
                result["messages"].append(text)

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
    result["stage"] = "open"
    c.mode(linuxcnc.MODE_AUTO)
    c.wait_complete()
    c.program_open(PROGRAM)
    c.wait_complete()
    wait(lambda: True, "open", 5)
    # The HAL pins and parameters as they are now, for diagnosis.
    with open(os.path.join(OUT, "hal.txt"), "w") as f:
        subprocess.run(["halcmd", "show", "all"], stdout=f, check=False)
    result["stage"] = "sampler"
    samplers = [Reader(k, cfg) for k, cfg in enumerate(CFGS)]
    try:
        subprocess.run(["halcmd", "sets", "mtwin-sample-on", "1"], check=True)
        result["stage"] = "run"
        c.feedrate(FEED_OVERRIDE)
        c.rapidrate(RAPID_OVERRIDE)
        c.wait_complete()
        c.auto(linuxcnc.AUTO_RUN, 0)
        wait(lambda: s.interp_state != linuxcnc.INTERP_IDLE, "the program to start", 10)
        wait(
            lambda: s.interp_state == linuxcnc.INTERP_IDLE and s.queue == 0 and s.inpos,
            "the program to end",
            TIMEOUT,
        )
        # A few idle periods after the end, then stop sampling.
        time.sleep(0.05)
        subprocess.run(["halcmd", "sets", "mtwin-sample-on", "0"], check=True)
    finally:
        for r in samplers:
            r.finish()
    result["stage"] = "done"
    result["ok"] = True


try:
    main()
except Exception as ex:  # reported to the test through result.json
    result["errors"].append("%s: %s" % (type(ex).__name__, ex))
save()
sys.exit(0 if result["ok"] else 1)
