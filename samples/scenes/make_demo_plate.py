#!/usr/bin/env python3
"""Writes demo_plate.json: the issue 6 demo part on the virtual machine. A plate 130 x 110 x 20 mm
with two D20 through-holes B and C and a D60 through-bore, clamped level on the table but
turned 0.35 deg about Z and offset, as a real part is: the alignment must find that.

Work frame (what plane-circle-circle alignment defines, seed 004): origin = centre of hole B on
the top face A, Y = B -> C. In it: B (0, 0), C (0, 60), bore (60, 30), plate x -25..105,
y -25..85, z -20..0. Captures: three of the top face (looking down from 120 mm), four of each
hole's wall and four of the bore's (tilted 30 deg into it, as the probe looks on a 3-axis machine
with the spindle oriented). Pure Python (no numpy); the JSON it wrote is committed beside it."""
import json
import math

from scene_math import rotation_vector

ROTATION_DEG = 0.35
OFFSET = (250.0, 120.0, -310.0)  # MCS of the work origin
HOLES = {"b": (0.0, 0.0, 10.0), "c": (0.0, 60.0, 10.0), "bore": (60.0, 30.0, 30.0)}
FACE_SPOTS = [(-15.0, 30.0), (100.0, -15.0), (100.0, 75.0)]
DEPTH = 20.0


def to_mcs(x, y, z=0.0):
    a = math.radians(ROTATION_DEG)
    return (OFFSET[0] + math.cos(a) * x - math.sin(a) * y,
            OFFSET[1] + math.sin(a) * x + math.cos(a) * y, OFFSET[2] + z)


def direction(x, y):
    a = math.radians(ROTATION_DEG)
    return (math.cos(a) * x - math.sin(a) * y, math.sin(a) * x + math.cos(a) * y, 0.0)


def pose(x_axis, z_axis, origin):
    """Flange pose with the probe's camera axes: columns x, y = z cross x, z."""
    y_axis = (z_axis[1] * x_axis[2] - z_axis[2] * x_axis[1],
              z_axis[2] * x_axis[0] - z_axis[0] * x_axis[2],
              z_axis[0] * x_axis[1] - z_axis[1] * x_axis[0])
    r = [[x_axis[i], y_axis[i], z_axis[i]] for i in range(3)]
    return {"translation_mm": [round(c, 9) for c in origin], "rotation_vector_rad": rotation_vector(r)}


def unit(v):
    n = math.sqrt(sum(c * c for c in v))
    return tuple(c / n for c in v)


def wall_capture(name, cx, cy, r, theta):
    """Looking into a hole at its wall sector at theta + 180 deg, tilted 30 deg from the axis."""
    radial = direction(math.cos(theta), math.sin(theta))
    centre = to_mcs(cx, cy, -DEPTH * 0.4)
    wall = tuple(centre[i] - r * radial[i] for i in range(3))
    tilt = math.radians(30)
    z_cam = unit(tuple(-math.sin(tilt) * radial[i] - math.cos(tilt) * (1.0 if i == 2 else 0.0) for i in range(3)))
    x_cam = unit(tuple(math.cos(tilt) * radial[i] - math.sin(tilt) * (1.0 if i == 2 else 0.0) for i in range(3)))
    origin = tuple(wall[i] - 120.0 * z_cam[i] for i in range(3))
    return {"id": name, "mcs_from_flange": pose(x_cam, z_cam, origin)}


def halfspace(x, y, z, nx, ny, nz):
    n = direction(nx, ny)
    return {"halfspace": {"point": [round(c, 9) for c in to_mcs(x, y, z)],
                          "normal": [round(n[0], 12), round(n[1], 12), nz]}}


def main():
    plate = {"intersection": [
        halfspace(-25, 0, 0, -1, 0, 0), halfspace(105, 0, 0, 1, 0, 0),
        halfspace(0, -25, 0, 0, -1, 0), halfspace(0, 85, 0, 0, 1, 0),
        {"halfspace": {"point": list(to_mcs(0, 0, 0)), "normal": [0, 0, 1]}},
        {"halfspace": {"point": list(to_mcs(0, 0, -DEPTH)), "normal": [0, 0, -1]}},
    ]}
    cuts = [{"cylinder": {"base": [round(c, 9) for c in to_mcs(x, y, -DEPTH - 1)], "axis": [0, 0, 1],
                          "radius": r, "length": DEPTH + 2}} for (x, y, r) in HOLES.values()]
    captures = []
    for k, (x, y) in enumerate(FACE_SPOTS):
        captures.append({"id": "face_%d" % (k + 1),
                         "mcs_from_flange": pose(direction(1, 0), (0, 0, -1), to_mcs(x, y, 120.0))})
    for name, (x, y, r) in HOLES.items():
        for q in range(4):
            captures.append(wall_capture("%s_wall_%d" % (name, 90 * q), x, y, r, q * math.pi / 2))
    scene = {
        "format": "mlprobe-scene/1",
        "comment": "Demo plate: D20 holes B (0,0) and C (0,60), D60 bore (60,30), 20 mm thick, in a "
                   "work frame turned %.2f deg about Z with its origin at MCS (%g, %g, %g). Written "
                   "by make_demo_plate.py." % ((ROTATION_DEG,) + OFFSET),
        "truth": {"work_origin_mcs_mm": list(OFFSET), "work_rotation_z_deg": ROTATION_DEG,
                  "bore_centre_mcs_mm": [round(c, 9) for c in to_mcs(60, 30)], "bore_diameter_mm": 60.0,
                  "hole_diameter_mm": 20.0},
        "flange_from_probe": {"translation_mm": [0, 0, 0], "rotation_vector_rad": [0, 0, 0]},
        "workpiece": {"difference": [plate] + cuts},
        "captures": captures,
    }
    with open("demo_plate.json", "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
