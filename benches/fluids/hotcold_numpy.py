"""The gridded hot/cold step of the FELT chapter, written directly in numpy: the baseline of
`cargo bench --bench peer_fluids`.

Grids of N^3 cells over [-1, 1]^3, samples at cell centres, arrays indexed [x, y, z]. Per frame:
  hot  = advect(hot, u) + ball(hotpoint);    cold = advect(cold, u) + ball(coldpoint)
  u    = advect(u, u) + dt * gravity * (cold - hot)
  u    = periodic FFT projection with the central-difference wavenumber sin(k h) / h
Advection is first-order semi-Lagrangian, q(x - u(x) dt), read trilinearly. The five
advected arrays (hot, cold, three velocity components) are read at the same back-traced
points, so the eight corner indices and weights are computed once per frame and shared by
the five gathers (np.take). The hot loop writes into work arrays made once (out=): fresh
16 MB temporaries each frame cost as much system time (page faults) as the arithmetic.
The FFTs are numpy.fft's (pocketfft, one thread).

Precision: float64 throughout (velocity, densities, weights, FFTs in complex128). felt stores
its density caches in float32 and its velocity in float64.

Edges follow felt's grid reads (docs: "Domains and caches", src/grid/interp.rs): a read
outside the box [-1, 1]^3 is zero; between the outermost cell centre and the box face (the
half-cell border) it extrapolates linearly from the two edge cells. Use --edges scipy to read
with scipy.ndimage.map_coordinates(order=1, mode='constant', cval=0) instead, one call per
array (the textbook form; slower, and zero from the outermost cell centres outwards).

Usage:
  hotcold_numpy.py --res 128 --warmup 2 --frames 5 [--edges scipy]
prints, per timed frame, "frame_seconds <s>" and its parts "advect_seconds <s>" (the five
advections) and "project_seconds <s>" (rfftn, projection, irfftn); then the values of the
agreement check: "hot <min> <max> <mean>", "cold ...", "probe_a <x> <y> <z>", "probe_b ...".
Missing numpy/scipy: prints "missing <what>" and exits with status 3.
"""

import argparse
import sys
import time

try:
    import numpy as np
except ImportError:
    print("missing numpy")
    sys.exit(3)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--warmup", type=int, default=2)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--dt", type=float, default=0.05)
    ap.add_argument("--gravity", type=float, default=-4.0)
    ap.add_argument("--edges", choices=["felt", "scipy"], default="felt")
    args = ap.parse_args()
    if args.edges == "scipy":
        try:
            from scipy.ndimage import map_coordinates
        except ImportError:
            print("missing scipy")
            sys.exit(3)
    else:
        map_coordinates = None

    n, dt = args.res, args.dt
    h = 2.0 / n
    gravity = np.array([0.0, args.gravity, 0.0])
    hotpoint = np.array([0.0, -0.5, 0.0])
    coldpoint = np.array([0.1, 0.5, 0.0])
    radius, rate = 0.25, 1.0

    # Cell centres, broadcastable [x, y, z].
    c = -1.0 + (np.arange(n) + 0.5) * h
    X, Y, Z = c[:, None, None], c[None, :, None], c[None, None, :]

    def ball(center):
        # injectball: mask(r^2 - |x - c|^2) * rate * dt, mask(f) = 1 where f >= 0.
        d2 = (X - center[0]) ** 2 + (Y - center[1]) ** 2 + (Z - center[2]) ** 2
        return np.where(radius * radius - d2 >= 0.0, rate * dt, 0.0)

    hot_source = ball(hotpoint)
    cold_source = ball(coldpoint)

    # Modified wavenumbers sin(k h) / h of the central difference; exactly zero at DC and at
    # the Nyquist frequency (where sin(pi) is 1e-16, not 0). rfftn halves the last axis (z).
    def wavenumber(m):
        k = 2.0 * np.pi * m / (n * h)
        s = np.sin(k * h) / h
        s[np.abs(m) * 2 == n] = 0.0
        s[m == 0] = 0.0
        return s

    sx = wavenumber(np.fft.fftfreq(n, 1.0 / n))[:, None, None]
    sy = wavenumber(np.fft.fftfreq(n, 1.0 / n))[None, :, None]
    sz = wavenumber(np.fft.rfftfreq(n, 1.0 / n))[None, None, :]
    s2 = sx * sx + sy * sy + sz * sz
    inv_s2 = np.divide(1.0, s2, out=np.zeros_like(s2), where=s2 > 0.0)

    def project(v):
        # v: (3, n, n, n), projected in place. Removes each mode's component along the wave
        # vector s; modes with s = 0 (DC, and those made only of Nyquist frequencies) are kept
        # as they are.
        vh = np.fft.rfftn(v, axes=(1, 2, 3))
        ax, ay, az = vh
        d = sx * ax
        d += sy * ay
        d += sz * az
        d *= inv_s2
        ax -= sx * d
        ay -= sy * d
        az -= sz * d
        v[...] = np.fft.irfftn(vh, s=(n, n, n), axes=(1, 2, 3))

    flat_n = n * n * n
    stride = (n * n, n, 1)
    # Cell index along each axis, broadcastable [x, y, z]: the index coordinate of a cell centre.
    index = [np.arange(n, dtype=np.float64).reshape(shape)
             for shape in ((n, 1, 1), (1, n, 1), (1, 1, n))]

    # Work arrays made once: fresh 16 MB temporaries every frame cost page faults (as much
    # system time as the arithmetic), so the hot loop writes into these with out=.
    w = [np.empty(flat_n) for _ in range(3)]
    clipped = np.empty(flat_n)
    base = np.empty(flat_n, dtype=np.intp)
    idx = np.empty(flat_n, dtype=np.intp)
    inside = np.empty(flat_n, dtype=bool)
    ok = np.empty(flat_n, dtype=bool)
    maskf = np.empty(flat_n)
    weights = [np.empty(flat_n) for _ in range(8)]
    at = [np.empty(flat_n, dtype=np.intp) for _ in range(8)]
    offsets = [cx * stride[0] + cy * stride[1] + cz * stride[2]
               for cx in (0, 1) for cy in (0, 1) for cz in (0, 1)]
    tmp = np.empty(flat_n)
    tmp2 = np.empty(flat_n)

    def advect_felt(fields, u, out):
        # fields, out: (5, n, n, n); each fields[k] is read at x - u(x) dt, x the cell
        # centres, into out[k]. Corner indices and weights are made once and shared by the five
        # arrays; points outside the box get zero weights.
        idx[:] = 0
        for a in range(3):
            wa = w[a]
            np.multiply(u[a].reshape(flat_n), -dt / h, out=wa)
            wa.reshape(n, n, n)[...] += index[a]  # index coordinate; the box is [-0.5, n - 0.5]
            if a == 0:
                np.greater_equal(wa, -0.5, out=inside)
            else:
                np.greater_equal(wa, -0.5, out=ok)
                np.logical_and(inside, ok, out=inside)
            np.less_equal(wa, n - 0.5, out=ok)
            np.logical_and(inside, ok, out=inside)
            np.clip(wa, 0.0, n - 2, out=clipped)
            np.copyto(base, clipped, casting="unsafe")  # truncation: the floor where wa >= 0
            wa -= base
            np.multiply(base, stride[a], out=base)
            np.add(idx, base, out=idx)
        np.copyto(maskf, inside)
        wx, wy, wz = w
        wx *= maskf  # weight of the upper x corner, zero outside
        c = 0
        for cx in (0, 1):
            if cx:
                fx = wx
            else:
                np.subtract(maskf, wx, out=tmp2)
                fx = tmp2
            for cy in (0, 1):
                if cy:
                    np.multiply(fx, wy, out=tmp)
                else:
                    np.subtract(fx, np.multiply(fx, wy, out=tmp), out=tmp)
                for cz in (0, 1):
                    if cz:
                        np.multiply(tmp, wz, out=weights[c])
                    else:
                        np.subtract(tmp, np.multiply(tmp, wz, out=weights[c]), out=weights[c])
                    np.add(idx, offsets[c], out=at[c])
                    c += 1
        for k in range(fields.shape[0]):
            flat = fields[k].reshape(flat_n)
            acc = out[k].reshape(flat_n)
            acc[:] = 0.0
            for weight, where in zip(weights, at):
                np.take(flat, where, out=tmp)
                np.multiply(tmp, weight, out=tmp)
                acc += tmp

    def advect_scipy(fields, u, out):
        # Index coordinates of the back-traced points, one map_coordinates call per array.
        coords = np.stack([index[a] - (dt / h) * u[a] for a in range(3)])
        for k in range(fields.shape[0]):
            out[k] = map_coordinates(fields[k], coords, order=1, mode="constant", cval=0.0)

    advect = advect_felt if args.edges == "felt" else advect_scipy

    # The state: hot, cold and the velocity's three components; two copies, swapped each
    # frame (advection reads one and writes the other).
    state = np.zeros((5, n, n, n))
    spare = np.zeros((5, n, n, n))
    buoy = np.empty((n, n, n))

    def frame(state, new):
        started = time.perf_counter()
        advect(state, state[2:], new)
        advected = time.perf_counter()
        new[0] += hot_source
        new[1] += cold_source
        np.subtract(new[1], new[0], out=buoy)
        for a in range(3):
            if gravity[a] != 0.0:
                new[2 + a] += (dt * gravity[a]) * buoy
        projecting = time.perf_counter()
        project(new[2:])
        return advected - started, time.perf_counter() - projecting

    for f in range(args.warmup + args.frames):
        start = time.perf_counter()
        advect_seconds, project_seconds = frame(state, spare)
        state, spare = spare, state
        seconds = time.perf_counter() - start
        if f >= args.warmup:
            print("frame_seconds", seconds)
            print("advect_seconds", advect_seconds)
            print("project_seconds", project_seconds)
        sys.stdout.flush()

    # The agreement check (after the timed frames), as hotcold.felt prints it.
    hot, cold, u = state[0], state[1], state[2:]
    def probe(q, point):
        # Trilinear read of one cell-centred array at a world point, felt's rule.
        uu = (np.asarray(point) + 1.0) / h - 0.5
        base = np.clip(uu, 0.0, n - 2).astype(np.int64)
        t = uu - base
        v = 0.0
        for cx in (0, 1):
            for cy in (0, 1):
                for cz in (0, 1):
                    wgt = ((t[0] if cx else 1 - t[0]) * (t[1] if cy else 1 - t[1])
                           * (t[2] if cz else 1 - t[2]))
                    v += wgt * q[base[0] + cx, base[1] + cy, base[2] + cz]
        return v

    print("hot", hot.min(), hot.max(), hot.mean())
    print("cold", cold.min(), cold.max(), cold.mean())
    for name, point in (("probe_a", (0.1, 0.2, 0.3)), ("probe_b", (0.0, -0.3, 0.05))):
        print(name, *[probe(u[a], point) for a in range(3)])


if __name__ == "__main__":
    main()
