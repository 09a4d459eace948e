#!/usr/bin/env python3
"""Writes a 2D implicit model in the SSA .vm format: rows of "glyphs" made of strokes (rectangles)
and rings, united by min, in [-1, 1]^2 — the structure of the Prospero challenge's text model,
with about 8,000 statements. Deterministic. Usage: make_text_vm.py OUT.vm [GLYPHS]"""
import random
import sys

out = sys.argv[1]
glyphs = int(sys.argv[2]) if len(sys.argv) > 2 else 330
rng = random.Random(1234)
lines = ["# isoforge test model: rows of glyphs of strokes and rings, a union by min (generated)"]
n = 0


def emit(op, *args):
    global n
    name = "_%x" % n
    n += 1
    lines.append(" ".join([name, op] + [str(a) for a in args]))
    return name


x = emit("var-x")
y = emit("var-y")


def const(v):
    return emit("const", "%.6g" % v)


def rect(cx, cy, hw, hh):
    dx = emit("sub", emit("abs", emit("sub", x, const(cx))), const(hw))
    dy = emit("sub", emit("abs", emit("sub", y, const(cy))), const(hh))
    return emit("max", dx, dy)


def ring(cx, cy, r, t):
    d = emit("sqrt", emit("add", emit("square", emit("sub", x, const(cx))), emit("square", emit("sub", y, const(cy)))))
    return emit("sub", emit("abs", emit("sub", d, const(r))), const(t))


cols, rows = 22, (glyphs + 21) // 22
w, h = 1.8 / cols, 1.8 / rows
shape = None
for g in range(glyphs):
    gx = -0.9 + (g % cols + 0.5) * w
    gy = 0.9 - (g // cols + 0.5) * h
    s = 0.35 * min(w, h)
    parts = []
    for _ in range(rng.randint(2, 3)):
        if rng.random() < 0.3:
            parts.append(ring(gx + rng.uniform(-0.3, 0.3) * s, gy + rng.uniform(-0.3, 0.3) * s, 0.6 * s, 0.08 * s))
        elif rng.random() < 0.5:
            parts.append(rect(gx + rng.uniform(-0.5, 0.5) * s, gy, 0.08 * s, s))
        else:
            parts.append(rect(gx, gy + rng.uniform(-0.8, 0.8) * s, 0.6 * s, 0.08 * s))
    for p in parts:
        shape = p if shape is None else emit("min", shape, p)
with open(out, "w") as f:
    f.write("\n".join(lines) + "\n")
print("%s: %d statements, %d glyphs" % (out, n, glyphs))
