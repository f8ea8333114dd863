#!/usr/bin/env python3
"""How well a simulated sequence's IMU measures each frame's translation (issue 36's slip check).

For every frame interval i -> i+1 of a sequence written by `hazmap simulate --imu-rate R`
(poses.txt = truth, odometry.txt = wheels, times.txt, imu.txt), the accelerometer's double
integral is compared with the true increment, in the best case a tracker could have:

  gyro:   orientation integrated from the gyro (its bias not removed), started at the true
          orientation of frame i, velocity at frame i the true one (the simulator's motion's);
  oracle: the true orientation along the interval (no gyro error at all), true velocity.

A wheel slip (the encoders' increment off by more than --slip metres) can be seen by the IMU only
where its error is well below the slip. Prints one summary line per mode and, with --frames,
every interval. docs/formats.md ("Can the IMU see a slip?").

  scripts/imu-translation-check.py SEQ [--slip 0.4] [--frames]
"""
import argparse

import numpy as np

GRAVITY = np.array([0.0, 0.0, -9.80665])  # the simulator's standard gravity, world z up


def read_poses(path):
    m = np.loadtxt(path).reshape(-1, 3, 4)
    return m[:, :, :3], m[:, :, 3]


def so3_exp(w):
    th = np.linalg.norm(w)
    if th < 1e-12:
        return np.eye(3)
    k = w / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


def so3_log(R):
    th = np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))
    if th < 1e-12:
        return np.zeros(3)
    return th / (2 * np.sin(th)) * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])


def integrate(samples, orientation, v0, h):
    """Position change over the interval from specific force, orientation(t) and start velocity."""
    dp, dv = np.zeros(3), np.zeros(3)
    for k, s in enumerate(samples):
        dt = (samples[k + 1, 0] if k + 1 < len(samples) else samples[0, 0] + h) - s[0]
        a = orientation(k, s) @ s[4:7] + GRAVITY
        dp += dv * dt + 0.5 * a * dt * dt
        dv += a * dt
    return v0 * h + dp


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("seq")
    ap.add_argument("--slip", type=float, default=0.4, help="m; a wheel increment this far off is a slip")
    ap.add_argument("--frames", action="store_true", help="print every interval")
    a = ap.parse_args()
    R, p = read_poses(f"{a.seq}/poses.txt")
    Rw, pw = read_poses(f"{a.seq}/odometry.txt")
    t = np.loadtxt(f"{a.seq}/times.txt")
    imu = np.loadtxt(f"{a.seq}/imu.txt", comments="#")
    rows = []
    for i in range(1, len(t) - 1):
        h = t[i + 1] - t[i]
        s = imu[(imu[:, 0] >= t[i]) & (imu[:, 0] < t[i + 1])]
        if len(s) == 0:
            continue
        v0 = (p[i + 1] - p[i - 1]) / (t[i + 1] - t[i - 1])  # the simulator's velocity at frame i
        truth = p[i + 1] - p[i]
        wheel = R[i] @ (Rw[i].T @ (pw[i + 1] - pw[i]))  # the encoders' increment, in the world
        state = {"R": R[i].copy(), "k": -1}

        def gyro(k, sample):
            if state["k"] >= 0:
                dt = sample[0] - state["t"]
                state["R"] = state["R"] @ so3_exp(state["w"] * dt)
            state.update(k=k, t=sample[0], w=sample[1:4])
            return state["R"]

        w = so3_log(R[i].T @ R[i + 1])
        oracle = lambda k, sample: R[i] @ so3_exp(w * (sample[0] - t[i]) / h)
        rows.append((i, h, np.linalg.norm(wheel - truth),
                     np.linalg.norm(integrate(s, gyro, v0, h) - truth),
                     np.linalg.norm(integrate(s, oracle, v0, h) - truth)))
    A = np.array(rows)
    if a.frames:
        print("frame  dt_s  wheel_err_m  imu_gyro_err_m  imu_oracle_err_m")
        for r in A:
            print("%5d %5.1f %12.3f %15.3f %17.3f" % tuple(r))
    slips = A[:, 2] > a.slip
    for col, name in ((3, "gyro"), (4, "oracle")):
        e = A[:, col]
        # A slip the IMU can tell: its own error is below half the wheels' (else the two disagree
        # by about as much on a good wheel increment).
        seen = (slips & (e < A[:, 2] / 2)).sum()
        print("%-6s intervals %d, slips %d; IMU translation error median %.3f m, 90th pct %.3f m, max %.3f m;"
              " slips the IMU could tell (its error below half the slip) %d of %d"
              % (name, len(A), slips.sum(), np.median(e), np.percentile(e, 90), e.max(), seen, slips.sum()))


if __name__ == "__main__":
    main()
