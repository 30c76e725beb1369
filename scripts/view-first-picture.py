#!/usr/bin/env python3
"""The time from a change of a live view's state to its first picture (docs/view.md).

Starts `BIN view --scene SCENE --slice z=0 --res 64 --threads 2 [FLAGS]`, waits for the first
state's first picture, then moves the slice seven times: each time it POSTs the new state and
times the reply of `/image.png?g=N`, which the view sends as soon as the first complete pass of
generation N is there. Prints each time with the pass it shows and the load average beside it
(the machine's other work counts: report it with the times).

    python3 scripts/view-first-picture.py target/release/ftpd3d scenes/cornell_mirror.obj
"""

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request


def main() -> None:
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    binary, scene, extra = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2]), sys.argv[3:]
    with tempfile.TemporaryDirectory() as cwd:
        view = subprocess.Popen(
            [binary, "view", "--scene", scene, "--slice", "z=0", "--res", "64", "--threads", "2", *extra],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, cwd=cwd)
        try:
            url = view.stdout.readline().strip()
            base, token = url.split("/?")[0], url.split("token=")[1].split("&")[0]

            def request(path: str, method: str = "GET") -> bytes:
                sep = "&" if "?" in path else "?"
                r = urllib.request.Request(f"{base}{path}{sep}token={token}", method=method)
                with urllib.request.urlopen(r, timeout=60) as f:
                    return f.read()

            request("/image.png?g=1")
            times = []
            for z in ["0.25", "-0.25", "0.5", "-0.5", "0.1", "-0.1", "0.3"]:
                t = time.perf_counter()
                g = json.loads(request(f"/state?slice=z%3D{z}", "POST"))["generation"]
                request(f"/image.png?g={g}")
                dt = time.perf_counter() - t
                times.append(dt)
                p = json.loads(request("/status"))["pass"]
                print(f"z={z}: first picture after {dt:.3f} s (pass {p['passes']}, "
                      f"{p['spp']:.0f} samples per cell), load average {os.getloadavg()[0]:.2f}")
                time.sleep(0.5)
            print(f"median {statistics.median(times):.3f} s, min {min(times):.3f} s, max {max(times):.3f} s")
        finally:
            view.terminate()
            view.wait()


if __name__ == "__main__":
    main()
