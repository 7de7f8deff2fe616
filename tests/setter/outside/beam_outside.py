#!/usr/bin/python3
"""A laser tool setter's receiver signal, written outside the setter's code (issue 56).

Shares no code and no model with host/setter's generator: its own beam, optics, tool and
electronics, so that `mlp setter` is judged on a signal it was not tuned to.

- Beam: Gaussian, waist w0 (1/e^2 radius), M^2 > 1, Rayleigh range zR = pi w0^2 / (M^2 lambda);
  along the beam (y) its radius w(y) = w0 sqrt(1 + ((y - y_focus) / zR)^2).
- Edge: the tool's silhouette seen along the beam is a straight edge at the reach of the
  point furthest into it; the light passed is the Gaussian's unblocked part, with Fresnel's
  straight-edge fringes (Born & Wolf 8.7) integrated over the profile: the rise before the
  fall comes from the first bright fringe (scaled so the rise is `rise` of the clear level).
  The blocking point's y (where the beam has its own width) is the tooth's, r sin(angle).
- Tool: teeth with a cutting edge, a circular land of its own width behind it, then relief;
  radial runout as an axis offset; the spindle's real speed off the commanded one.
- Electronics: a first-order amplifier (its own bandwidth), Gaussian noise, a 12-bit ADC over
  a full scale, a slow drift of the laser's power.
- Coolant drops: flat-bottomed dimming (ramps, a flat of its own depth and length).

Truth: the axis position (along the approach, + into the beam) at every sample, and the
position at which the longest tooth's reach meets the beam's centre (the 50 % light of a
straight edge, whatever the beam's width there).
"""
import json
import math
import sys

import numpy as np

WAVELENGTH_MM = 650e-6
OVERSAMPLE = 8


def fresnel_edge_table():
    """Fresnel's straight-edge intensity I(v), v > 0 into the lit side, as a table."""
    v = np.linspace(-12.0, 40.0, 52001)
    # C(v), S(v) by integrating cos, sin of pi t^2 / 2 from 0 (trapezoid on a fine grid).
    dv = v[1] - v[0]
    c_int = np.concatenate([[0.0], np.cumsum(0.5 * dv * (np.cos(np.pi * v[1:] ** 2 / 2) +
                                                        np.cos(np.pi * v[:-1] ** 2 / 2)))])
    s_int = np.concatenate([[0.0], np.cumsum(0.5 * dv * (np.sin(np.pi * v[1:] ** 2 / 2) +
                                                        np.sin(np.pi * v[:-1] ** 2 / 2)))])
    zero = np.searchsorted(v, 0.0)
    c_int -= c_int[zero]
    s_int -= s_int[zero]
    return v, 0.5 * ((c_int + 0.5) ** 2 + (s_int + 0.5) ** 2)


class Beam:
    """The light passed by a straight edge, as a table over u = intrusion / w."""

    def __init__(self, rise):
        v, intensity = fresnel_edge_table()
        s = np.linspace(-3.0, 3.0, 1201)  # across the beam, in units of w
        g = np.exp(-2 * s ** 2)
        g /= g.sum()
        self.u = np.linspace(-3.0, 3.0, 1201)

        def passed(kappa):
            # Edge at u: lit where s < -u (the tool comes from +s); Fresnel's v = kappa (-u - s).
            vv = kappa * (-self.u[:, None] - s[None, :])
            return (np.interp(vv, v, intensity, left=0.0, right=1.0) * g[None, :]).sum(axis=1)

        # The fringe scale that gives the rise asked for (bisection on kappa: larger, sharper).
        lo, hi = 0.5, 200.0
        for _ in range(60):
            mid = math.sqrt(lo * hi)
            if passed(mid).max() - 1.0 > rise:
                lo = mid
            else:
                hi = mid
        self.share = passed(math.sqrt(lo * hi))

    def half_light_u(self):
        """Where a straight edge passes half the light, in units of w."""
        i = int(np.argmax(self.share < 0.5))
        return float(np.interp(0.5, [self.share[i], self.share[i - 1]], [self.u[i], self.u[i - 1]]))

    def passed(self, intrusion_mm, w_mm):
        return np.interp(intrusion_mm / w_mm, self.u, self.share, left=1.0, right=0.0)


def tooth_profile(r_mm, land_mm, relief_deg, rng):
    """A tooth's outline near its tip, as (angle behind the edge [rad], radius [mm]) points:
    the cutting edge at 0, the land (radius r) behind it, then relief; ahead of the edge the
    rake face falls into the flute."""
    land = land_mm / r_mm
    pts = [(-0.02 * k, r_mm - 0.05 * k) for k in range(3, 0, -1)]  # rake face
    pts += [(a, r_mm) for a in np.linspace(0.0, land, 12)]
    relief = math.tan(math.radians(relief_deg))
    pts += [(land + a, r_mm - relief * r_mm * a) for a in np.linspace(0.002, 0.08, 16)]
    return np.array(pts)


def tool_reach(t_s, tool, axis_mm):
    """The reach into the beam (past its centre) of the tool's furthest point, and its y."""
    turn = 2 * np.pi * tool["rps_true"] * t_s + tool["phase"]
    reach = np.full(t_s.shape, -1e9)
    y_at = np.zeros(t_s.shape)
    n = len(tool["radii"])
    ex, ey = tool["runout_xy"]
    for k in range(n):
        prof = tool["profiles"][k]
        base = turn + 2 * np.pi * k / n
        for ang, rad in prof:
            a = base - ang  # the land trails the edge as the tool turns
            x = rad * np.cos(a) + ex * np.cos(turn) - ey * np.sin(turn)
            y = rad * np.sin(a) + ex * np.sin(turn) + ey * np.cos(turn)
            better = x > reach
            reach = np.where(better, x, reach)
            y_at = np.where(better, y, y_at)
    core = tool["core_mm"]
    better = core > reach
    reach = np.where(better, core, reach)
    y_at = np.where(better, 0.0, y_at)
    return axis_mm + reach, y_at


def max_reach(tool):
    """The longest tooth's reach past the axis (turned to face the beam), numerically."""
    t = np.linspace(0, 1.0 / tool["rps_true"], 200001)
    reach, _ = tool_reach(t, tool, 0.0)
    return reach.max()


def first_order(u, alpha, block=64):
    """y[n] = y[n-1] + alpha (u[n] - y[n-1]), y[-1] = u[0]: in blocks of `block` samples, each
    the closed form y[n0+j] = q^(j+1) y[n0-1] + alpha sum_k q^(j-k) u[n0+k], q = 1 - alpha
    (numpy has no recursive filter; scipy's lfilter is not a dependency here)."""
    q = 1.0 - alpha
    n = len(u)
    pad = (-n) % block
    blocks = np.concatenate([u, np.full(pad, u[-1])]).reshape(-1, block)
    j = np.arange(block)
    grow, shrink = q ** (-j), q ** (j + 1)
    partial = alpha * np.cumsum(blocks * grow[None, :], axis=1) * (q ** j)[None, :]
    out = np.empty_like(blocks)
    prev = u[0]
    for b in range(blocks.shape[0]):
        out[b] = partial[b] + shrink * prev
        prev = out[b, -1]
    return out.reshape(-1)[:n]


def render(case, beam_table):
    fs = case["sample_rate_hz"]
    fs_in = fs * OVERSAMPLE
    feed = case["feed_mm_min"] / 60.0
    d = 1.0 if case["entering"] else -1.0
    n = int(case["duration_s"] * fs)
    t = np.arange(n * OVERSAMPLE) / fs_in
    tool = case["tool"]
    r_max = case["truth_reach_mm"]
    # Entering, the longest tooth starts `gap` before the centre; leaving, `gap` past it.
    axis0 = -r_max - d * case["gap_mm"]
    axis = axis0 + d * feed * t
    if tool["rpm"] > 0:
        reach, y = tool_reach(t, tool, axis)
    else:
        reach, y = axis + tool["radii"][0], np.zeros(t.shape)
    b = case["beam"]
    w = b["w0_mm"] * np.sqrt(1 + ((y - b["y_focus_mm"]) / b["zr_mm"]) ** 2)
    light = beam_table.passed(reach, w)
    rng = np.random.default_rng(case["noise_seed"])
    for drop in case["drops"]:  # flat-bottomed: ramps in and out, a flat between
        t0, ramp, flat, depth = drop["t_s"], drop["ramp_s"], drop["flat_s"], drop["depth"]
        shape = np.clip(np.minimum((t - t0) / ramp, (t0 + 2 * ramp + flat - t) / ramp), 0, 1)
        light = light * (1 - depth * shape)
    e = case["electronics"]
    power = e["clear_v"] * (1 + e["drift_per_s"] * t +
                            e["drift_wobble"] * np.sin(2 * np.pi * t / e["wobble_s"] + e["wobble_phase"]))
    u = power * light
    # The amplifier: first order, exact for a piecewise-constant input between fine samples.
    alpha = 1 - math.exp(-2 * math.pi * e["bandwidth_hz"] / fs_in)
    out = first_order(u, alpha)
    sampled = out[::OVERSAMPLE] + rng.normal(0, e["noise_v"], n)
    lsb = e["full_scale_v"] / 4096
    codes = np.clip(np.round(sampled / lsb), 0, 4095).astype(int)
    axis_samples = axis[::OVERSAMPLE]
    return codes, lsb, axis_samples


def write_signal(path, fs, codes, electronics, axis_mm):
    """As a real setter's logger would (mlprobe-beam-signal/2): ADC codes, time, the axis."""
    with open(path, "w") as f:
        f.write("# mlprobe-beam-signal/2 sample_rate_hz=%.6g adc_bits=12 full_scale_v=%g "
                "amplifier_hz=%.1f\n" % (fs, electronics["full_scale_v"], electronics["bandwidth_hz"]))
        f.write("# columns: t_s code axis_mm\n")
        f.write("".join("%.9f %d %.7f\n" % (i / fs, c, a)
                        for i, (c, a) in enumerate(zip(codes, axis_mm))))


def make_tool(rng, diameter_mm, teeth, rpm, runout_tir_um):
    radii = diameter_mm / 2 + rng.uniform(-0.004, 0.004, teeth)  # ground unequal
    ecc = runout_tir_um / 2000.0
    ang = rng.uniform(0, 2 * np.pi)
    profiles = [tooth_profile(r, rng.uniform(0.03, 0.2), rng.uniform(5, 12), rng) for r in radii]
    rps_true = rpm / 60.0 * (1 + rng.uniform(0.0005, 0.002)) if rpm > 0 else 0.0
    return {"rpm": rpm, "radii": radii.tolist(), "profiles": profiles,
            "runout_xy": (ecc * math.cos(ang), ecc * math.sin(ang)),
            "phase": rng.uniform(0, 2 * np.pi), "rps_true": rps_true,
            "core_mm": 0.55 * diameter_mm / 2}


def make_beam(rng):
    w0 = rng.uniform(0.018, 0.030)
    m2 = rng.uniform(1.1, 1.4)
    return {"w0_mm": w0, "zr_mm": math.pi * w0 ** 2 / (m2 * WAVELENGTH_MM),
            "y_focus_mm": rng.uniform(-0.5, 0.5), "m2": m2}


def make_electronics(rng):
    return {"clear_v": rng.uniform(3.2, 4.3), "full_scale_v": 5.0,
            "noise_v": rng.uniform(0.002, 0.006), "bandwidth_hz": rng.uniform(8000, 20000),
            "drift_per_s": rng.uniform(-0.003, 0.003), "drift_wobble": rng.uniform(0, 0.002),
            "wobble_s": rng.uniform(1.0, 4.0), "wobble_phase": rng.uniform(0, 2 * np.pi)}


def make_drops(rng, count, t_lo, t_hi):
    return [{"t_s": float(rng.uniform(t_lo, t_hi)), "ramp_s": float(rng.uniform(5e-5, 3e-4)),
             "flat_s": float(rng.uniform(2e-4, 3e-3)), "depth": float(rng.uniform(0.3, 0.95))}
            for _ in range(count)]


def make_case(seed):
    """One seeded case: a pin's calibration on a beam, and a tool through the same beam."""
    rng = np.random.default_rng(seed)
    beam, elec = make_beam(rng), make_electronics(rng)
    fs = float(rng.choice([45000, 50000, 64000, 80000, 96000]))
    diameter = float(rng.choice([3, 4, 6, 8, 10, 12, 16, 20]))
    teeth = int(rng.choice([2, 2, 3, 4]))
    rpm = float(rng.choice([1000, 1500, 2000, 3000, 4000, 6000]))
    per_turn_um = float(rng.choice([4, 4, 8, 12, 20, 20]))
    feed = per_turn_um / 1000 * rpm
    tool = make_tool(rng, diameter, teeth, rpm, float(rng.uniform(0, 10)))
    entering = bool(rng.random() < 0.7)
    gap = 0.06 + 2 * per_turn_um / 1000
    duration = (gap + 0.06) / (feed / 60.0)
    # Drops: most cases some, over the approach before the crossing.
    drops = make_drops(rng, int(rng.choice([0, 0, 2, 5])), 0.02, 0.9 * gap / (feed / 60.0))
    case = {"seed": seed, "beam": beam, "electronics": elec, "sample_rate_hz": fs,
            "diameter_mm": diameter, "teeth": teeth, "rpm": rpm, "per_turn_um": per_turn_um,
            "feed_mm_min": feed, "entering": entering, "gap_mm": gap, "duration_s": duration,
            "tool": tool, "drops": drops, "noise_seed": seed * 7 + 1}
    case["truth_reach_mm"] = max_reach(tool)
    pin = {"sample_rate_hz": fs, "feed_mm_min": 6.0, "entering": True, "gap_mm": 0.12,
           "duration_s": 0.24 / 0.1, "beam": beam, "electronics": elec, "drops": [],
           "tool": {"rpm": 0.0, "radii": [3.0]}, "truth_reach_mm": 3.0,
           "noise_seed": seed * 7 + 2}
    return case, pin


def main(argv):
    """beam_outside.py SEED OUT_PREFIX: writes OUT_PREFIX.pin.txt, .tool.txt, .json (truth)."""
    seed, prefix = int(argv[1]), argv[2]
    case, pin = make_case(seed)
    table = Beam(rise=0.013)
    codes, _, axis = render(pin, table)
    write_signal(prefix + ".pin.txt", pin["sample_rate_hz"], codes, pin["electronics"], axis)
    codes, _, axis = render(case, table)
    write_signal(prefix + ".tool.txt", case["sample_rate_hz"], codes, case["electronics"], axis)
    truth = {k: case[k] for k in ("seed", "sample_rate_hz", "diameter_mm", "teeth", "rpm",
                                  "per_turn_um", "feed_mm_min", "entering", "drops", "beam",
                                  "electronics")}
    truth["tooth_radii_mm"] = case["tool"]["radii"]
    truth["rpm_true"] = case["tool"]["rps_true"] * 60
    truth["truth_reach_mm"] = case["truth_reach_mm"]
    truth["axis_start_mm"] = float(axis[0])
    truth["axis_mm_per_sample"] = float(axis[1] - axis[0])
    # The edge: where the axis is when the longest tooth, turned to face the beam, passes half
    # the light (Fresnel's fringes move that off the beam's centre; the pin's curve has it too).
    b = case["beam"]
    w_tip = b["w0_mm"] * math.sqrt(1 + (b["y_focus_mm"] / b["zr_mm"]) ** 2)
    truth["half_light_intrusion_mm"] = table.half_light_u() * w_tip
    truth["axis_at_edge_mm"] = -case["truth_reach_mm"] + truth["half_light_intrusion_mm"]
    with open(prefix + ".json", "w") as f:
        json.dump(truth, f, indent=1)


if __name__ == "__main__":
    main(sys.argv)
