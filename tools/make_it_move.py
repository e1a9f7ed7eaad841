#!/usr/bin/env python3
"""Make the simulated drive move, and plot what it did.

Connects to a running `canopen-drive-linux` (README, command 1) over python-canopen, enables
the drive through the CiA 402 state machine, and runs three motions one after the other:

1. profile position (pp, 6060h = 1): a move to 60 000 increments and back to 20 000;
2. profile velocity (pv, 6060h = 3): a ramp up to 20 000 inc/s, down through zero to
   -30 000 inc/s, and to a stop (the axis ends below the home switch);
3. homing (hm, 6060h = 6), method 3: find the home switch (20 000..30 000 on the simulated
   axis) in the positive direction, then the index pulse; 6064h reads 0 there.

To watch it, the script maps the position demand (6062h) and the actual position (6064h) into
TPDO 3, the velocity demand (606Bh) and the actual velocity (606Ch) into TPDO 4, both sent
every 10 ms (event timer) once the node is Operational, records them, and at the end writes an
SVG plot (no plotting library needed) and switches the drive off again (Ready to switch on).

    .venv/bin/python tools/make_it_move.py                       # node 5 on 127.0.0.1:29536
    .venv/bin/python tools/make_it_move.py --out target/move.svg --port 29536 --node-id 5

Exits with status 1, saying which step failed, when the drive does not do what is asked
(tests/python/test_make_it_move.py runs it against a fresh drive).
"""

import argparse
import math
import pathlib
import struct
import sys
import threading
import time

import canopen

CONTROLWORD, STATUSWORD = 0x6040, 0x6041
MODES, MODES_DISPLAY = 0x6060, 0x6061
POSITION_DEMAND, POSITION_ACTUAL = 0x6062, 0x6064
VELOCITY_DEMAND, VELOCITY_ACTUAL = 0x606B, 0x606C
TARGET_POSITION, PROFILE_VELOCITY = 0x607A, 0x6081
PROFILE_ACCELERATION, PROFILE_DECELERATION = 0x6083, 0x6084
HOMING_METHOD, HOMING_SPEEDS, HOMING_ACCELERATION = 0x6098, 0x6099, 0x609A
TARGET_VELOCITY = 0x60FF
PP, PV, HM = 1, 3, 6


class MoveFailed(Exception):
    pass


class Drive:
    """The few SDO accesses the script needs, without an EDS."""

    def __init__(self, network: canopen.Network, node_id: int):
        self.node = network.add_node(node_id)
        self.node.sdo.RESPONSE_TIMEOUT = 1.0

    def write(self, index, sub, fmt, value):
        self.node.sdo.download(index, sub, struct.pack(fmt, value))

    def read(self, index, sub, fmt):
        return struct.unpack(fmt, self.node.sdo.upload(index, sub))[0]

    def statusword(self):
        return self.read(STATUSWORD, 0, "<H")

    def control(self, word):
        self.write(CONTROLWORD, 0, "<H", word)

    def wait(self, what, condition, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            status = self.statusword()
            if condition(status):
                return status
            time.sleep(0.01)
        raise MoveFailed(f"{what}: not within {timeout} s (statusword {self.statusword():04X}h)")

    def mode(self, mode):
        self.write(MODES, 0, "<b", mode)
        deadline = time.monotonic() + 2
        while self.read(MODES_DISPLAY, 0, "<b") != mode:
            if time.monotonic() > deadline:
                raise MoveFailed(f"mode {mode} not taken (6061h)")
            time.sleep(0.01)


class Sampler:
    """Demand and actual values from TPDO 3 (6062h, 6064h) and TPDO 4 (606Bh, 606Ch)."""

    def __init__(self, network: canopen.Network, drive: Drive, node_id: int):
        self.samples = []  # (t, position demand, position, velocity demand, velocity)
        self.marks = []  # (t, label)
        self.lock = threading.Lock()
        self.position = None
        self.start_time = time.monotonic()
        for pdo, cob_id, entries in ((2, 0x380 + node_id, (POSITION_DEMAND, POSITION_ACTUAL)),
                                     (3, 0x480 + node_id, (VELOCITY_DEMAND, VELOCITY_ACTUAL))):
            communication, mapping = 0x1800 + pdo, 0x1A00 + pdo
            drive.write(communication, 1, "<I", 0x8000_0000 | 0x4000_0000 | cob_id)  # invalid while mapping
            drive.write(mapping, 0, "<B", 0)
            for sub, index in enumerate(entries, start=1):
                drive.write(mapping, sub, "<I", index << 16 | 0x20)  # sub 0, 32 bits
            drive.write(mapping, 0, "<B", len(entries))
            drive.write(communication, 2, "<B", 255)  # event-driven
            drive.write(communication, 3, "<H", 100)  # inhibit time 10 ms (100 µs units)
            drive.write(communication, 5, "<H", 10)  # event timer 10 ms
            drive.write(communication, 1, "<I", 0x4000_0000 | cob_id)  # valid
        network.subscribe(0x380 + node_id, self._positions)
        network.subscribe(0x480 + node_id, self._velocities)

    def _positions(self, _cob_id, data, _timestamp):
        with self.lock:
            self.position = struct.unpack("<ii", bytes(data))

    def _velocities(self, _cob_id, data, _timestamp):
        with self.lock:
            if self.position is not None:
                t = time.monotonic() - self.start_time
                self.samples.append((t, *self.position, *struct.unpack("<ii", bytes(data))))

    def mark(self, label):
        self.marks.append((time.monotonic() - self.start_time, label))


def enable(drive: Drive):
    status = drive.statusword()
    if status & 0x004F == 0x0008:  # Fault: fault reset (0 -> 1 edge of bit 7)
        drive.control(0x0000)
        drive.control(0x0080)
    drive.control(0x0006)  # Shutdown
    drive.wait("Ready to switch on", lambda s: s & 0x006F == 0x0021, 2)
    drive.control(0x0007)  # Switch on
    drive.wait("Switched on", lambda s: s & 0x006F == 0x0023, 2)
    drive.control(0x000F)  # Enable operation
    drive.wait("Operation enabled", lambda s: s & 0x006F == 0x0027, 2)


def profile_position(drive: Drive, sampler: Sampler):
    drive.mode(PP)
    drive.write(PROFILE_VELOCITY, 0, "<I", 40_000)
    drive.write(PROFILE_ACCELERATION, 0, "<I", 80_000)
    drive.write(PROFILE_DECELERATION, 0, "<I", 80_000)
    for target in (60_000, 20_000):
        sampler.mark(f"pp to {target}")
        drive.write(TARGET_POSITION, 0, "<i", target)
        drive.control(0x001F)  # new set-point (bit 4), single set-point, absolute
        drive.wait("set-point acknowledged", lambda s: s & 0x1000, 2)
        drive.control(0x000F)
        drive.wait(f"target {target} reached", lambda s: s & 0x0400 and not s & 0x1000, 10)
        actual = drive.read(POSITION_ACTUAL, 0, "<i")
        if abs(actual - target) > 100:
            raise MoveFailed(f"pp: at {actual}, target {target}")


def profile_velocity(drive: Drive, sampler: Sampler):
    drive.mode(PV)
    drive.write(PROFILE_ACCELERATION, 0, "<I", 40_000)
    drive.write(PROFILE_DECELERATION, 0, "<I", 40_000)
    for velocity, hold in ((20_000, 0.4), (-30_000, 0.8), (0, 0.0)):
        sampler.mark(f"pv {velocity}")
        drive.write(TARGET_VELOCITY, 0, "<i", velocity)
        time.sleep(0.05)  # bit 10 belongs to the new target from the next tick on
        drive.wait(f"velocity {velocity} reached", lambda s: s & 0x0400, 5)
        time.sleep(hold)
    deadline = time.monotonic() + 5
    while abs(drive.read(VELOCITY_ACTUAL, 0, "<i")) > 100:
        if time.monotonic() > deadline:
            raise MoveFailed("pv: the axis does not come to rest")
        time.sleep(0.02)


def homing(drive: Drive, sampler: Sampler):
    drive.mode(HM)
    drive.write(HOMING_METHOD, 0, "<b", 3)
    drive.write(HOMING_SPEEDS, 1, "<I", 30_000)  # search for the switch
    drive.write(HOMING_SPEEDS, 2, "<I", 5_000)  # search for the index pulse
    drive.write(HOMING_ACCELERATION, 0, "<I", 100_000)
    sampler.mark("homing (method 3)")
    drive.control(0x001F)  # start (bit 4)
    status = drive.wait("homing attained", lambda s: s & 0x2000 or (s & 0x1400 == 0x1400), 20)
    if status & 0x2000:
        raise MoveFailed(f"homing error (statusword {status:04X}h)")
    drive.control(0x000F)
    actual = drive.read(POSITION_ACTUAL, 0, "<i")
    if abs(actual) > 100:
        raise MoveFailed(f"homing: 6064h reads {actual} at home, not 0")


def nice_ticks(lo, hi, count=5):
    """Round values inside lo..hi for the axis ticks: a step of 1, 2 or 5 times a power of ten,
    the smallest that gives at most about `count` of them (a reader takes in 20 000, 40 000, …
    faster than 24 390, 43 975, …)."""
    span = (hi - lo) or abs(hi) or 1.0
    raw = span / count
    power = 10 ** math.floor(math.log10(raw))
    step = next(m * power for m in (1, 2, 5, 10) if m * power >= raw)
    digits = max(0, -math.floor(math.log10(step)))
    first, last = math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9)
    return [round(k * step, digits) + 0.0 for k in range(first, last + 1)]


def plot(samples, marks, path: pathlib.Path):
    """Two panels (position, velocity), demand and actual, as SVG: round ticks on both axes;
    each panel's title, and the events, above its frame, clear of the data."""
    width, left, right, top, title_space, panel, axis_space = 960, 90, 20, 34, 24, 230, 34
    t_end = max(s[0] for s in samples) or 1.0
    t_ticks = nice_ticks(0.0, t_end, 8)
    panels = [
        ("position (increments)", 1, 2),
        ("velocity (increments/s)", 3, 4),
    ]
    height = top + len(panels) * (title_space + panel + axis_space) + 30

    def x(t):
        return left + (width - left - right) * t / t_end

    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'font-family="sans-serif" font-size="12">',
        f'<rect width="{width}" height="{height}" fill="white"/>',
        f'<text x="{left}" y="22" font-size="15">canopen-drive-linux, live: pp move, pv ramp, homing '
        "(from TPDOs every 10 ms)</text>",
    ]
    y0 = top
    for title, demand_col, actual_col in panels:
        y0 += title_space
        values = [s[demand_col] for s in samples] + [s[actual_col] for s in samples]
        lo, hi = min(values + [0]), max(values + [0])
        span = (hi - lo) or 1.0
        lo, hi = lo - 0.05 * span, hi + 0.05 * span
        ticks = nice_ticks(lo, hi)

        def y(v, lo=lo, hi=hi, y0=y0):
            return y0 + panel * (hi - v) / (hi - lo)

        parts.append(f'<text x="{width - right}" y="{y0 - 8}" font-weight="bold" text-anchor="end">{title}</text>')
        for v in ticks:
            parts.append(f'<line x1="{left}" x2="{width - right}" y1="{y(v):.1f}" y2="{y(v):.1f}" stroke="#eee"/>')
            parts.append(f'<text x="{left - 6}" y="{y(v) + 4:.1f}" text-anchor="end">{v:,.0f}</text>')
        for t in t_ticks:
            parts.append(f'<line x1="{x(t):.1f}" x2="{x(t):.1f}" y1="{y0 + panel}" y2="{y0 + panel + 4}" stroke="#888"/>')
            parts.append(f'<text x="{x(t):.1f}" y="{y0 + panel + 17}" text-anchor="middle">{t:g} s</text>')
        parts.append(f'<rect x="{left}" y="{y0}" width="{width - left - right}" height="{panel}" '
                     'fill="none" stroke="#888"/>')
        for t, label in marks:
            parts.append(f'<line x1="{x(t):.1f}" x2="{x(t):.1f}" y1="{y0}" y2="{y0 + panel}" '
                         'stroke="#bbb" stroke-dasharray="4 3"/>')
            if y0 == top + title_space:  # the events above the first panel, beside its title
                parts.append(f'<text x="{x(t) + 3:.1f}" y="{y0 - 8}" fill="#666">{label}</text>')
        for col, colour, dash in ((demand_col, "#1f77b4", "6 3"), (actual_col, "#d62728", "")):
            points = " ".join(f"{x(s[0]):.1f},{y(s[col]):.1f}" for s in samples)
            dashes = f' stroke-dasharray="{dash}"' if dash else ""
            parts.append(f'<polyline points="{points}" fill="none" stroke="{colour}" stroke-width="1.6"{dashes}/>')
        y0 += panel + axis_space
    legend_y = height - 14
    parts.append(f'<line x1="{left}" x2="{left + 30}" y1="{legend_y}" y2="{legend_y}" stroke="#1f77b4" '
                 'stroke-width="2" stroke-dasharray="6 3"/>')
    parts.append(f'<text x="{left + 36}" y="{legend_y + 4}">demand (6062h, 606Bh)</text>')
    parts.append(f'<line x1="{left + 220}" x2="{left + 250}" y1="{legend_y}" y2="{legend_y}" stroke="#d62728" '
                 'stroke-width="2"/>')
    parts.append(f'<text x="{left + 256}" y="{legend_y + 4}">actual (6064h, 606Ch)</text>')
    parts.append("</svg>")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(parts) + "\n")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=29536)
    parser.add_argument("--node-id", type=int, default=5)
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("target/move.svg"))
    args = parser.parse_args(argv)
    channel = f"socket://{args.host}:{args.port}"

    network = canopen.Network()
    try:
        network.connect(interface="slcan", channel=channel, bitrate=500000, sleep_after_open=0)
    except Exception as error:  # noqa: BLE001 - say what to do, whatever python-can raised
        print(f"cannot connect to {channel} ({error}): is the drive running (README, command 1)?", file=sys.stderr)
        return 1
    drive = Drive(network, args.node_id)
    sampler = None
    failed = None
    try:
        network.nmt.send_command(0x80)  # Pre-operational: PDOs may be configured
        time.sleep(0.05)
        sampler = Sampler(network, drive, args.node_id)
        network.nmt.send_command(0x01)  # Operational: the TPDOs run
        enable(drive)
        print("enabled (Operation enabled); TPDO 3 and 4 every 10 ms")
        time.sleep(0.2)
        for name, step in (("profile position", profile_position), ("profile velocity", profile_velocity),
                           ("homing", homing)):
            step(drive, sampler)
            print(f"{name}: done")
        time.sleep(0.3)
    except (MoveFailed, canopen.SdoAbortedError, canopen.SdoCommunicationError) as error:
        failed = error
    finally:
        try:
            drive.control(0x0006)  # back to Ready to switch on: no torque
        except (canopen.SdoAbortedError, canopen.SdoCommunicationError):
            pass
        network.disconnect()
    if sampler is not None and sampler.samples:
        with sampler.lock:
            samples = list(sampler.samples)
        plot(samples, sampler.marks, args.out)
        print(f"plot of {len(sampler.samples)} samples: {args.out}")
    if failed is not None:
        print(f"make_it_move: {failed}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
