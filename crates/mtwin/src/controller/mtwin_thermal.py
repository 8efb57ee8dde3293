#!/usr/bin/python3
"""mtwin live thermal compensation for LinuxCNC (userspace HAL component).

Written by `mtwin export --thermal MODEL.toml --to linuxcnc` with the thermal
drift model of `mtwin thermal fit` built in (MODEL below). Load it from a HAL
file (thermal.hal, written beside it, does this):

    loadusr -Wn mtwin-thermal /usr/bin/python3 mtwin_thermal.py --clock-pin

Every poll (--poll-s, default T/300 between 0.005 and 0.05 s, T the model
period) it reads its input pins (in.<column>:
the spindle speed in rev/min and, when the model was fitted with them, the
other inputs such as temperatures, in the units of the training data). Each
input is held from one poll to the next and averaged over every model period
T ([0, T), [T, 2T), ...; time 0 is the clock's zero: with --clock-pin the
pin clock-s, s, which thermal.hal drives with the servo thread's time, else
the wall clock from the component's start). At the end of
period k the ARX model of every measured height is stepped once with those
means, which gives the drift e(kT) at each height; the drift at the current
tool height (pin --z-pin, default axis.z.pos-cmd, interpolated linearly
between the measured heights, the end values held outside) is then held over
the next period, the way the source method of mtwin's thermal compensation
(docs/references.md, [R4]) updates the correction at each period mark.

Outputs: drift-mm (tool relative to workpiece, +Z, mm), offset-mm (= -drift,
the Z correction), counts (offset-mm / RESOLUTION_MM rounded, for
axis.z.eoffset-counts with axis.z.eoffset-scale = RESOLUTION_MM), sample (k)
and time-s (the component's clock at the last poll). Each poll writes sample
first and time-s last, so the outputs of one complete poll satisfy
k T <= time-s < (k+1) T. LinuxCNC adds changes
of eoffset-counts to the offset only while motion is enabled and every joint
is homed, and zeroes the offset when motion is enabled. So while --enable-pin
(default motion.motion-enabled) is false the counts are 0 (the whole offset
comes back when the machine is switched on again), and while --homed-pin
(default motion.is-all-homed) is false the counts hold their last value (a
change then would be lost, leaving the offset off the counts until the
machine is switched off).

Options: --clock-pin takes the time from the input pin clock-s (seconds)
instead of the wall clock; for tests and demonstrations --period-s S runs the
model with a period of S seconds instead of its own (a time lapse).
"""
import argparse
import json
import sys
import time

import hal

MODEL = json.loads(r"""@MODEL@""")
RESOLUTION_MM = @RESOLUTION@


class Arx:
    """Free-run ARX model from rest, stepped one sample at a time.

    e(k) = -sum_i a_i e(k-i) + sum_inputs sum_j b_j u(k-j-nk); step(u(k))
    returns e(k+1) (every input delay nk >= 1).
    """

    def __init__(self, a, b, nk):
        self.a = a
        self.b = b
        self.nk = nk
        self.y = [0.0] * (len(a) - 1)
        self.u = [[0.0] * (len(bi) + ki - 1) for bi, ki in zip(b, nk)]

    def step(self, inputs):
        for hist, v in zip(self.u, inputs):
            if hist:
                hist.insert(0, v)
                hist.pop()
        y = 0.0
        for ai, yp in zip(self.a[1:], self.y):
            y -= ai * yp
        for bi, ki, hist in zip(self.b, self.nk, self.u):
            for bj, v in zip(bi, hist[ki - 1:]):
                y += bj * v
        if self.y:
            self.y.insert(0, y)
            self.y.pop()
        return y


def interpolate(zs, values, z):
    """Drift at height z from the values at the ascending heights zs."""
    if z < zs[0]:
        return values[0]
    if z > zs[-1]:
        return values[-1]
    i = 0
    while i < len(zs) and zs[i] <= z:
        i += 1
    if i >= len(zs):
        return values[-1]
    z0, z1 = zs[i - 1], zs[i]
    w = (z - z0) / (z1 - z0)
    return values[i - 1] + w * (values[i] - values[i - 1])


class Thermal:
    """The drift model of MODEL fed with period means of the inputs."""

    def __init__(self, model, period_s):
        self.period_s = period_s
        self.columns = model["columns"]
        self.inputs = model["inputs"]
        self.zs = [h["z_mm"] for h in model["heights"]]
        self.models = [Arx(h["a"], h["b"], h["nk"]) for h in model["heights"]]
        self.drifts = [0.0] * len(self.zs)
        self.k = 0
        self.t = 0.0
        self.held = [0.0] * len(self.columns)
        self.acc = [0.0] * len(self.columns)

    def scaled(self, means):
        return [
            (means[c["column"]] / c["scale"]) ** c["power"] for c in self.inputs
        ]

    def advance(self, now, values):
        """Moves the clock to `now` (s); `values` are read now and held."""
        if now < self.t:
            now = self.t
        while now >= (self.k + 1) * self.period_s:
            end = (self.k + 1) * self.period_s
            means = [
                (a + h * (end - self.t)) / self.period_s
                for a, h in zip(self.acc, self.held)
            ]
            u = self.scaled(means)
            self.drifts = [m.step(u) for m in self.models]
            self.k += 1
            self.t = end
            self.acc = [0.0] * len(self.columns)
        self.acc = [a + h * (now - self.t) for a, h in zip(self.acc, self.held)]
        self.t = now
        self.held = list(values)

    def drift(self, z):
        return interpolate(self.zs, self.drifts, z)


def main(argv):
    p = argparse.ArgumentParser(description="mtwin live thermal compensation (HAL)")
    p.add_argument("--name", default="mtwin-thermal", help="HAL component name")
    p.add_argument("--poll-s", type=float,
                   help="poll interval, s (default T/300 within [0.005, 0.05], T the period)")
    p.add_argument("--period-s", type=float, help="model period, s (default the model's)")
    p.add_argument("--clock-pin", action="store_true", help="time from pin clock-s")
    p.add_argument("--z-pin", default="axis.z.pos-cmd", help="pin of the tool height, mm")
    p.add_argument("--z-mm", type=float, help="fixed tool height, mm (instead of --z-pin)")
    p.add_argument("--enable-pin", default="motion.motion-enabled",
                   help="bit pin: counts are 0 while it is false ('' for always on)")
    p.add_argument("--homed-pin", default="motion.is-all-homed",
                   help="bit pin: counts hold while it is false ('' for always homed)")
    args = p.parse_args(argv)
    period_s = args.period_s if args.period_s else MODEL["period_min"] * 60.0
    if not period_s > 0.0:
        p.error("--period-s must be positive")
    thermal = Thermal(MODEL, period_s)
    poll_s = args.poll_s if args.poll_s else min(0.05, max(0.005, period_s / 300.0))

    c = hal.component(args.name)
    for col in thermal.columns:
        c.newpin("in." + col, hal.HAL_FLOAT, hal.HAL_IN)
    c.newpin("clock-s", hal.HAL_FLOAT, hal.HAL_IN)
    c.newpin("drift-mm", hal.HAL_FLOAT, hal.HAL_OUT)
    c.newpin("offset-mm", hal.HAL_FLOAT, hal.HAL_OUT)
    c.newpin("counts", hal.HAL_S32, hal.HAL_OUT)
    c.newpin("sample", hal.HAL_S32, hal.HAL_OUT)
    c.newpin("time-s", hal.HAL_FLOAT, hal.HAL_OUT)
    c.newpin("z-mm", hal.HAL_FLOAT, hal.HAL_OUT)
    c.ready()

    t0 = time.monotonic()
    limit = 2 ** 31 - 1
    counts = 0
    try:
        while True:
            now = c["clock-s"] if args.clock_pin else time.monotonic() - t0
            values = [c["in." + col] for col in thermal.columns]
            thermal.advance(now, values)
            z = args.z_mm if args.z_mm is not None else hal.get_value(args.z_pin)
            drift = thermal.drift(z)
            on = True if not args.enable_pin else bool(hal.get_value(args.enable_pin))
            homed = True if not args.homed_pin else bool(hal.get_value(args.homed_pin))
            if not on:
                counts = 0
            elif homed:
                counts = int(round(-drift / RESOLUTION_MM))
            # sample first and time-s last: a reader that sees the pins
            # between two writes of one poll (the servo thread samples them
            # while this process writes) finds sample k with a time-s outside
            # period k whenever the poll crossed a period end.
            c["sample"] = thermal.k
            c["drift-mm"] = drift
            c["offset-mm"] = -drift
            c["counts"] = max(-limit, min(limit, counts))
            c["z-mm"] = z
            c["time-s"] = now
            time.sleep(poll_s)
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main(sys.argv[1:])
