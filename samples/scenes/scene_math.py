"""Rotation helpers shared by the sample scene generators (pure Python, no numpy)."""
import math


def rotation_vector(r):
    """Via the quaternion (Shepperd's method): stable for every angle, including near pi."""
    t = r[0][0] + r[1][1] + r[2][2]
    if t > max(r[0][0], r[1][1], r[2][2]):
        w = math.sqrt(1 + t) / 2
        v = [(r[2][1] - r[1][2]) / (4 * w), (r[0][2] - r[2][0]) / (4 * w), (r[1][0] - r[0][1]) / (4 * w)]
    else:
        i = max(range(3), key=lambda k: r[k][k])
        j, k = (i + 1) % 3, (i + 2) % 3
        s = math.sqrt(1 + r[i][i] - r[j][j] - r[k][k]) * 2
        v = [0.0, 0.0, 0.0]
        v[i] = s / 4
        v[j] = (r[j][i] + r[i][j]) / s
        v[k] = (r[k][i] + r[i][k]) / s
        w = (r[k][j] - r[j][k]) / s
    n = math.sqrt(sum(x * x for x in v))
    if n < 1e-15:
        return [0.0, 0.0, 0.0]
    angle = 2 * math.atan2(n, w)
    return [round(angle * x / n, 12) for x in v]
