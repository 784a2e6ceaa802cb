#!/usr/bin/env python3
"""URDF -> serial chain description for the real-robot benchmark (bench/robots_bench.cpp) and its
test (tests/robots/). Standard library only.

Walks the joints from a base link to a tip link and writes a plain-text chain, one record a line:

    robot NAME
    base LINK
    tip LINK
    segment NAME TYPE x y z roll pitch yaw ax ay az lower upper
        every URDF joint on the path as written (TYPE fixed / revolute / continuous / prismatic),
        for Orocos KDL, which takes URDF's frames as they are (one segment per joint)
    joint NAME TYPE x y z qw qx qy qz ax ay az lower upper
        every moving joint, with the fixed joints before it folded into its origin (translation in
        the parent frame, then the rotation as a unit quaternion), axis unit length in the joint's
        frame; lower/upper in rad (m for prismatic), nan for a continuous joint
    tool x y z qw qx qy qz
        the fixed joints after the last moving joint, composed: the tool frame in the last joint's
        frame (a hand, a TCP)

URDF's joint frame is the parent link's frame moved by the origin (xyz in the parent frame, then
rpy as fixed-axis roll about x, pitch about y, yaw about z: R = Rz(yaw) Ry(pitch) Rx(roll)); the
joint turns (or slides) about its axis in that frame, and the child link's frame is the result.

    tools/urdf_chain.py ROBOT.urdf BASE_LINK TIP_LINK [--name NAME] [-o OUT]
"""
import argparse
import math
import sys
import xml.etree.ElementTree as ET

MOVING = ("revolute", "continuous", "prismatic")


def quat_mul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


def quat_rotate(q, v):
    w, x, y, z = q
    p = quat_mul(quat_mul(q, (0.0, v[0], v[1], v[2])), (w, -x, -y, -z))
    return (p[1], p[2], p[3])


def quat_from_rpy(roll, pitch, yaw):
    def about(axis, angle):
        s = math.sin(0.5 * angle)
        q = [math.cos(0.5 * angle), 0.0, 0.0, 0.0]
        q[1 + axis] = s
        return tuple(q)
    return quat_mul(about(2, yaw), quat_mul(about(1, pitch), about(0, roll)))


def compose(a, b):
    """Transform a then b (b expressed in a's frame): (p, q) pairs."""
    pa, qa = a
    pb, qb = b
    r = quat_rotate(qa, pb)
    return (tuple(pa[i] + r[i] for i in range(3)), quat_mul(qa, qb))


def floats(text, default, count=3):
    if text is None:
        return default
    values = [float(v) for v in text.split()]
    if len(values) != count:
        raise ValueError(f"expected {count} numbers, got {text!r}")
    return tuple(values)


def path_joints(root, base, tip):
    """The URDF joints from base to tip, in order (each link has one parent joint)."""
    by_child = {}
    for j in root.findall("joint"):
        by_child[j.find("child").get("link")] = j
    links = {l.get("name") for l in root.findall("link")}
    for name in (base, tip):
        if name not in links:
            raise ValueError(f"no link named {name!r}")
    path = []
    link = tip
    while link != base:
        j = by_child.get(link)
        if j is None:
            raise ValueError(f"{tip!r} is not below {base!r}")
        path.append(j)
        link = j.find("parent").get("link")
    return list(reversed(path))


def describe(urdf_path, base, tip, name):
    root = ET.parse(urdf_path).getroot()
    lines = [f"# tools/urdf_chain.py {urdf_path} {base} {tip}", f"robot {name or root.get('name')}",
             f"base {base}", f"tip {tip}"]
    identity = ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))
    pending = identity  # fixed joints not yet folded into a moving joint
    moving = 0
    for j in path_joints(root, base, tip):
        jtype = j.get("type")
        if jtype not in MOVING + ("fixed",):
            raise ValueError(f"joint {j.get('name')}: type {jtype} is not a serial-chain joint")
        origin = j.find("origin")
        xyz = floats(origin.get("xyz") if origin is not None else None, (0.0, 0.0, 0.0))
        rpy = floats(origin.get("rpy") if origin is not None else None, (0.0, 0.0, 0.0))
        axis_el = j.find("axis")
        axis = floats(axis_el.get("xyz") if axis_el is not None else None, (1.0, 0.0, 0.0))  # URDF's default
        lower = upper = math.nan
        if jtype in ("revolute", "prismatic"):
            limit = j.find("limit")
            if limit is None:
                raise ValueError(f"joint {j.get('name')}: a {jtype} joint needs <limit>")
            lower, upper = float(limit.get("lower", 0.0)), float(limit.get("upper", 0.0))
        if jtype == "fixed":
            axis = (0.0, 0.0, 0.0)
        lines.append("segment %s %s %s" % (j.get("name"), jtype,
                                          " ".join(repr(v) for v in xyz + rpy + axis + (lower, upper))))
        transform = compose(pending, (xyz, quat_from_rpy(*rpy)))
        if jtype == "fixed":
            pending = transform
            continue
        norm = math.sqrt(sum(a * a for a in axis))
        if not norm > 0.0:
            raise ValueError(f"joint {j.get('name')}: zero axis")
        unit = tuple(a / norm for a in axis)
        p, q = transform
        lines.append("joint %s %s %s" % (j.get("name"), jtype,
                                        " ".join(repr(v) for v in p + q + unit + (lower, upper))))
        pending = identity
        moving += 1
    if moving == 0:
        raise ValueError(f"no moving joint between {base!r} and {tip!r}")
    p, q = pending
    lines.append("tool %s" % " ".join(repr(v) for v in p + q))
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("urdf")
    ap.add_argument("base_link")
    ap.add_argument("tip_link")
    ap.add_argument("--name", help="robot name in the output (default: the URDF's)")
    ap.add_argument("-o", "--out", help="output file (default: stdout)")
    args = ap.parse_args()
    try:
        text = describe(args.urdf, args.base_link, args.tip_link, args.name)
    except (ValueError, ET.ParseError, OSError) as e:
        print(f"urdf_chain: {args.urdf}: {e}", file=sys.stderr)
        return 1
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
