#!/usr/bin/env python3
"""Writes demo_plate.json: the issue 6 demo part on the virtual machine. A plate 130 x 110 x 20 mm
with two D20 through-holes B and C and a through-bore roughed to 59.90 for its finishing pass
to 60.00, clamped level on the table but turned 0.35 deg about Z and offset, as a real part is:
the alignment must find that. Beside it the reference sphere for the hand-eye; the probe's true
mounting M is not the identity (the hand-eye must find it).

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
# The bore before its finishing pass: 59.90 for a finished 60.00 (seed 004's example).
HOLES = {"b": (0.0, 0.0, 10.0), "c": (0.0, 60.0, 10.0), "bore": (60.0, 30.0, 29.95)}
# The reference sphere for the hand-eye, beside the plate (work frame), and the probe's true
# mounting M (what the hand-eye must find): 1.5 deg about (1, 1, 0), offset (4, -2.5, 35) mm.
SPHERE = (-70.0, 30.0, 10.0, 12.7)
M_AXIS_ANGLE = ((1 / math.sqrt(2), 1 / math.sqrt(2), 0.0), math.radians(1.5))
M_TRANSLATION = (4.0, -2.5, 35.0)
SPHERE_VIEWS = 8
FACE_SPOTS = [(-15.0, 30.0), (100.0, -15.0), (100.0, 75.0)]
DEPTH = 20.0


def to_mcs(x, y, z=0.0):
    a = math.radians(ROTATION_DEG)
    return (OFFSET[0] + math.cos(a) * x - math.sin(a) * y,
            OFFSET[1] + math.sin(a) * x + math.cos(a) * y, OFFSET[2] + z)


def direction(x, y):
    a = math.radians(ROTATION_DEG)
    return (math.cos(a) * x - math.sin(a) * y, math.sin(a) * x + math.cos(a) * y, 0.0)


def axis_angle_matrix(axis, angle):
    x, y, z = axis
    c, s, t = math.cos(angle), math.sin(angle), 1 - math.cos(angle)
    return [[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c]]


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def pose(x_axis, z_axis, origin):
    """The flange pose H putting the probe's camera axes (columns x, y = z cross x, z) at
    `origin`: H = (mcs_from_probe) M^-1."""
    y_axis = (z_axis[1] * x_axis[2] - z_axis[2] * x_axis[1],
              z_axis[2] * x_axis[0] - z_axis[0] * x_axis[2],
              z_axis[0] * x_axis[1] - z_axis[1] * x_axis[0])
    r_probe = [[x_axis[i], y_axis[i], z_axis[i]] for i in range(3)]
    r_m = axis_angle_matrix(*M_AXIS_ANGLE)
    r_m_inv = [[r_m[j][i] for j in range(3)] for i in range(3)]
    r = matmul(r_probe, r_m_inv)
    t = [origin[i] - sum(r[i][k] * M_TRANSLATION[k] for k in range(3)) for i in range(3)]
    return {"translation_mm": [round(c, 9) for c in t], "rotation_vector_rad": rotation_vector(r)}


def sphere_capture(k):
    """Looking at the sphere from a cone of directions, the spindle oriented differently each
    time and the sphere at different places in the view (else M's tilt trades against its
    offset along the optical axis)."""
    sx, sy, sz, _ = SPHERE
    centre = to_mcs(sx, sy, sz)
    tilt = math.radians(10.0 + 12.5 * (k % 3))
    az = 2 * math.pi * k / SPHERE_VIEWS
    view = (math.sin(tilt) * math.cos(az), math.sin(tilt) * math.sin(az), -math.cos(tilt))
    x = unit((view[2], 0.0, -view[0]))  # perpendicular to the view
    y = (view[1] * x[2] - view[2] * x[1], view[2] * x[0] - view[0] * x[2], view[0] * x[1] - view[1] * x[0])
    roll = 0.7 * k
    xr = tuple(math.cos(roll) * x[i] + math.sin(roll) * y[i] for i in range(3))
    yr = (view[1] * xr[2] - view[2] * xr[1], view[2] * xr[0] - view[0] * xr[2], view[0] * xr[1] - view[1] * xr[0])
    in_view = (4.0 * math.cos(1.9 * k), 3.0 * math.sin(2.3 * k), 118.0 + 8.0 * math.sin(1.3 * k))
    origin = tuple(centre[i] - (xr[i] * in_view[0] + yr[i] * in_view[1] + view[i] * in_view[2])
                   for i in range(3))
    return {"id": "sphere_%d" % k, "mcs_from_flange": pose(xr, view, origin)}


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
    sphere = {"sphere": {"center": [round(c, 9) for c in to_mcs(*SPHERE[:3])], "radius": SPHERE[3]},
              "reflectance": 0.6}
    cuts = [{"cylinder": {"base": [round(c, 9) for c in to_mcs(x, y, -DEPTH - 1)], "axis": [0, 0, 1],
                          "radius": r, "length": DEPTH + 2}} for (x, y, r) in HOLES.values()]
    captures = [sphere_capture(k) for k in range(SPHERE_VIEWS)]
    for k, (x, y) in enumerate(FACE_SPOTS):
        captures.append({"id": "face_%d" % (k + 1),
                         "mcs_from_flange": pose(direction(1, 0), (0, 0, -1), to_mcs(x, y, 120.0))})
    for name, (x, y, r) in HOLES.items():
        for q in range(4):
            captures.append(wall_capture("%s_wall_%d" % (name, 90 * q), x, y, r, q * math.pi / 2))
    scene = {
        "format": "mlprobe-scene/1",
        "comment": "Demo plate: D20 holes B (0,0) and C (0,60), a bore (60,30) at 59.90 before its "
                   "finishing pass to 60, 20 mm thick, the reference sphere R12.7 at (-70,30,10), in a "
                   "work frame turned %.2f deg about Z with its origin at MCS (%g, %g, %g). Written "
                   "by make_demo_plate.py." % ((ROTATION_DEG,) + OFFSET),
        "truth": {"work_origin_mcs_mm": list(OFFSET), "work_rotation_z_deg": ROTATION_DEG,
                  "bore_centre_mcs_mm": [round(c, 9) for c in to_mcs(60, 30)], "bore_diameter_mm": 59.9,
                  "hole_diameter_mm": 20.0},
        "flange_from_probe": {"translation_mm": list(M_TRANSLATION),
                              "rotation_vector_rad": [M_AXIS_ANGLE[1] * c for c in M_AXIS_ANGLE[0]]},
        "workpiece": {"union": [{"difference": [plate] + cuts}, sphere]},
        "captures": captures,
    }
    with open("demo_plate.json", "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
