#!/usr/bin/env python3
"""The naive baseline: a numpy interpreter of the SSA .vm format, evaluating every statement on all
pixels of an N x N grid over [-1, 1]^2 at z = 0 (row 0 at y = +1), then thresholding at 0.
Prints the seconds taken and the number of inside pixels. Usage: vm_numpy.py MODEL.vm [N]"""
import sys
import time

import numpy as np

path = sys.argv[1]
n = int(sys.argv[2]) if len(sys.argv) > 2 else 1024
text = open(path).read()
t0 = time.perf_counter()
s = (np.arange(n, dtype=np.float32) + 0.5) * (2.0 / n) - 1.0
x, y = np.meshgrid(s, -s)
z = np.zeros_like(x)
v = {}
out = None
for line in text.splitlines():
    line = line.split("#")[0].split()
    if not line:
        continue
    name, op, args = line[0], line[1], line[2:]
    a = [v[k] for k in args] if op != "const" else []
    if op == "const":
        r = np.float32(float(args[0]))
    elif op == "var-x":
        r = x
    elif op == "var-y":
        r = y
    elif op == "var-z":
        r = z
    elif op == "add":
        r = a[0] + a[1]
    elif op == "sub":
        r = a[0] - a[1]
    elif op == "mul":
        r = a[0] * a[1]
    elif op == "div":
        r = a[0] / a[1]
    elif op == "min":
        r = np.minimum(a[0], a[1])
    elif op == "max":
        r = np.maximum(a[0], a[1])
    elif op == "neg":
        r = -a[0]
    elif op == "square":
        r = a[0] * a[0]
    elif op == "sqrt":
        r = np.sqrt(a[0])
    elif op == "abs":
        r = np.abs(a[0])
    elif op == "exp":
        r = np.exp(a[0])
    elif op == "ln":
        r = np.log(a[0])
    elif op == "sin":
        r = np.sin(a[0])
    elif op == "cos":
        r = np.cos(a[0])
    else:
        raise SystemExit("unknown op " + op)
    v[name] = r
    out = r
inside = int(np.count_nonzero(out < 0))
print("%.4f %d" % (time.perf_counter() - t0, inside))
