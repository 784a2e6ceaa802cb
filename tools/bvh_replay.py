#!/usr/bin/env python3
"""A CMU BVH clip as a Godot humanoid and its effector goals, for bench/godot/body.gd --mode=replay.

    tools/bvh_replay.py CLIP.bvh OUT.json [--metres-per-unit X] [--frames N]

The skeleton keeps every BVH joint; the joints IKBody.setup_humanoid() needs are renamed to
SkeletonProfileHumanoid's names (CMU: LowerBack -> Spine, Spine -> Chest, Spine1 -> UpperChest,
LeftUpLeg -> LeftUpperLeg, LeftLeg -> LeftLowerLeg, LeftArm -> LeftUpperArm, LeftForeArm ->
LeftLowerArm; Hips, Neck, Head, LeftFoot, LeftShoulder, LeftHand keep theirs; Boxing_Toes: Ab ->
Spine, LeftCollar -> LeftShoulder, LeftShoulder -> LeftUpperArm, LeftElbow -> LeftLowerArm,
LeftWrist -> LeftHand, LeftHip/Knee/Ankle -> LeftUpperLeg/LowerLeg/Foot, no UpperChest; pass
--metres-per-unit 0.01 for it). Each bone gets a
rest orientation whose +Y points at its child and whose +X is the hinge axis setup_humanoid()
reads (world X for legs and spine, world Y for the arms, which lie along X in CMU's T-pose); the
recording's global rotation G_j of a joint maps to the bone's global basis G_j * Q_j. The hips'
rest origin is frame 0's hips position. Per frame: every joint's recorded position (m) and the
six effector targets (position, quaternion x y z w), as body_bench.cpp replays them.
"""
import json
import math
import sys

CMU_UNIT = (1.0 / 0.45) * 2.54 / 100.0  # body_bench.cpp's clip table: ASF/AMC lengths -> m
RENAME = {"LowerBack": "Spine", "Spine": "Chest", "Spine1": "UpperChest",
          "LeftUpLeg": "LeftUpperLeg", "LeftLeg": "LeftLowerLeg", "RightUpLeg": "RightUpperLeg",
          "RightLeg": "RightLowerLeg", "LeftArm": "LeftUpperArm", "LeftForeArm": "LeftLowerArm",
          "RightArm": "RightUpperArm", "RightForeArm": "RightLowerArm"}
# Boxing_Toes (the other skeleton of the clips) names its joints otherwise and has two spine bones
# (no UpperChest: SkeletonProfileHumanoid's optional bones).
RENAME_BOXING = {"Ab": "Spine", "LeftCollar": "LeftShoulder", "LeftShoulder": "LeftUpperArm",
                 "LeftElbow": "LeftLowerArm", "LeftWrist": "LeftHand", "RightCollar": "RightShoulder",
                 "RightShoulder": "RightUpperArm", "RightElbow": "RightLowerArm", "RightWrist": "RightHand",
                 "LeftHip": "LeftUpperLeg", "LeftKnee": "LeftLowerLeg", "LeftAnkle": "LeftFoot",
                 "RightHip": "RightUpperLeg", "RightKnee": "RightLowerLeg", "RightAnkle": "RightFoot"}
EFFECTORS = ["Hips", "LeftHand", "RightHand", "LeftFoot", "RightFoot", "Head"]


def qmul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def qaxis(axis, deg):
    h = math.radians(deg) / 2
    s = math.sin(h)
    return {"X": (s, 0, 0, math.cos(h)), "Y": (0, s, 0, math.cos(h)), "Z": (0, 0, s, math.cos(h))}[axis]


def qrot(q, v):
    x, y, z, w = q
    p = qmul(qmul(q, (v[0], v[1], v[2], 0.0)), (-x, -y, -z, w))
    return p[:3]


def qconj(q):
    return (-q[0], -q[1], -q[2], q[3])


def mat_to_quat(m):  # m: columns x, y, z
    (m00, m10, m20), (m01, m11, m21), (m02, m12, m22) = m
    tr = m00 + m11 + m22
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        return ((m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s)
    if m00 > m11 and m00 > m22:
        s = math.sqrt(1.0 + m00 - m11 - m22) * 2
        return (0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s)
    if m11 > m22:
        s = math.sqrt(1.0 + m11 - m00 - m22) * 2
        return ((m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s)
    s = math.sqrt(1.0 + m22 - m00 - m11) * 2
    return ((m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s)


def norm(v):
    n = math.sqrt(sum(c * c for c in v))
    return tuple(c / n for c in v)


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def parse(path):
    tokens = open(path).read().split()
    joints = []  # name, parent, offset, channels, end (child offset list)
    stack = []
    i = 0
    while tokens[i] != "MOTION":
        t = tokens[i]
        if t in ("ROOT", "JOINT"):
            joints.append({"name": tokens[i + 1], "parent": stack[-1] if stack else -1, "children": [],
                           "end": None})
            if stack:
                joints[stack[-1]]["children"].append(len(joints) - 1)
            stack.append(len(joints) - 1)
            i += 2
        elif t == "End":
            stack.append("end")
            i += 2
        elif t == "OFFSET":
            off = tuple(float(x) for x in tokens[i + 1:i + 4])
            if stack[-1] == "end":
                joints[stack[-2]]["end"] = off
            else:
                joints[stack[-1]]["offset"] = off
            i += 4
        elif t == "CHANNELS":
            n = int(tokens[i + 1])
            joints[stack[-1]]["channels"] = tokens[i + 2:i + 2 + n]
            i += 2 + n
        elif t == "}":
            stack.pop()
            i += 1
        else:
            i += 1
    frames = int(tokens[i + 2])
    i += 6  # MOTION Frames: N Frame Time: dt
    data = [float(x) for x in tokens[i:]]
    return joints, frames, data


def main():
    args = sys.argv[1:]
    src, out = args[0], args[1]
    unit = CMU_UNIT
    limit = None
    if "--metres-per-unit" in args:
        unit = float(args[args.index("--metres-per-unit") + 1])
    if "--frames" in args:
        limit = int(args[args.index("--frames") + 1])
    joints, frames, data = parse(src)
    width = sum(len(j["channels"]) for j in joints)
    frames = min(frames, len(data) // width, limit or frames)
    rename = RENAME_BOXING if any(j["name"] == "Ab" for j in joints) else RENAME
    names = [rename.get(j["name"], j["name"]) for j in joints]
    # Rest orientation per joint (global): +Y toward the child (the first child with a non-zero
    # offset; the neck's parent toward the neck), +X world X (legs, spine) or world Y (arms).
    rest_q = []
    for k, j in enumerate(joints):
        target = None
        kids = j["children"]
        kids = [c for c in kids if names[c] == "Neck"] + kids
        for c in kids:
            if math.sqrt(sum(x * x for x in joints[c]["offset"])) > 1e-6:
                target = joints[c]["offset"]
                break
        if target is None and j["end"] is not None and math.sqrt(sum(x * x for x in j["end"])) > 1e-6:
            target = j["end"]
        if target is None or names[k] == "Hips":
            rest_q.append((0.0, 0.0, 0.0, 1.0))
            continue
        y = norm(target)
        ref = (1.0, 0.0, 0.0) if abs(y[0]) < 0.7 else (0.0, 1.0, 0.0)
        z = norm(cross(ref, y))
        x = cross(y, z)
        rest_q.append(mat_to_quat((x, y, z)))
    # Per frame: global rotation and position of every joint.
    positions, targets = [], []
    for f in range(frames):
        row = data[f * width:(f + 1) * width]
        col = 0
        g_rot, g_pos = [], []
        for k, j in enumerate(joints):
            loc = (0.0, 0.0, 0.0, 1.0)
            pos = None
            for ch in j["channels"]:
                v = row[col]
                col += 1
                if ch.endswith("position"):
                    pos = pos or [0.0, 0.0, 0.0]
                    pos["XYZ".index(ch[0])] = v * unit
                else:
                    loc = qmul(loc, qaxis(ch[0], v))
            off = tuple(c * unit for c in j["offset"])
            if j["parent"] < 0:
                p = tuple((pos or [0, 0, 0])[a] + off[a] for a in range(3))
                r = loc
            else:
                pr, pp = g_rot[j["parent"]], g_pos[j["parent"]]
                d = qrot(pr, off)
                p = tuple(pp[a] + d[a] for a in range(3))
                r = qmul(pr, loc)
            g_rot.append(r)
            g_pos.append(p)
        positions.append([round(c, 6) for p in g_pos for c in p])
        t = {}
        for e in EFFECTORS:
            k = names.index(e)
            q = qmul(g_rot[k], rest_q[k])
            t[e] = [round(c, 7) for c in g_pos[k]] + [round(c, 9) for c in q]
        targets.append(t)
    # Local rests: Q_parent^-1 Q_j, origin Q_parent^-1 * offset (BVH rests carry no rotation).
    bones = []
    for k, j in enumerate(joints):
        off = tuple(c * unit for c in j["offset"])
        if j["parent"] < 0:
            origin = tuple(positions[0][a] for a in range(3))
            basis = rest_q[k]
        else:
            qp = rest_q[j["parent"]]
            origin = qrot(qconj(qp), off)
            basis = qmul(qconj(qp), rest_q[k])
        bones.append({"name": names[k], "parent": j["parent"], "origin": list(origin), "rotation": list(basis)})
    json.dump({"source": src, "metres_per_unit": unit, "frames": frames, "bones": bones,
               "joint_positions": positions, "targets": targets}, open(out, "w"))
    print(f"{src}: {len(bones)} bones, {frames} frames -> {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
