#!/usr/bin/env python3
"""What the realism figures cost a web job: starts `ridgeline serve` on a library,
submits the same sketch (a PNG, sent as the page sends it) with `realism` off and on,
alternately, and prints per-stage medians and the evaluation's share of the job.

usage: scripts/bench-service-realism.py BINARY LIBRARY SKETCH.png [RUNS]
"""
import base64, json, os, statistics, subprocess, sys, tempfile, time, urllib.request

binary, library, sketch = sys.argv[1:4]
runs = int(sys.argv[4]) if len(sys.argv) > 4 else 3
work = tempfile.mkdtemp(prefix="rl-bench-")
server = subprocess.Popen(
    [binary, "serve", "--listen", "127.0.0.1:0", "--exemplars", library, "--jobs-dir", os.path.join(work, "jobs"),
     "--cache-dir", os.path.join(work, "cache"), "--gpu", "off"],
    stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
url = server.stdout.readline().replace("ridgeline is serving on ", "").strip().rstrip("/")
png = base64.b64encode(open(sketch, "rb").read()).decode()


def call(path, body=None):
    req = urllib.request.Request(url + path, data=body and json.dumps(body).encode(),
                                 headers={"Content-Type": "application/json"} if body else {})
    with urllib.request.urlopen(req) as r:
        return json.loads(r.read())


def job(realism):
    s = call("/api/jobs", {"sketch": {"png_base64": png}, "seed": 1, "realism": realism})
    while s["state"] in ("queued", "running"):
        time.sleep(0.2)
        s = call(f"/api/jobs/{s['id']}")
    assert s["state"] == "done", s
    report = call(f"/api/jobs/{s['id']}/files/report.json")
    stages = {t["stage"]: t["seconds"] for t in report["stages"]}
    return s["seconds"], stages, report.get("evaluation") is not None


try:
    results = {False: [], True: []}
    job(True)  # the first job fills the source figures' cache, as a service's first job does
    for _ in range(runs):
        for realism in (False, True):
            results[realism].append(job(realism))
    for realism in (False, True):
        rows = results[realism]
        assert all(r[2] == realism for r in rows), "report has evaluation iff realism"
        job_s = statistics.median(r[0] for r in rows)
        print(f"realism {'on ' if realism else 'off'}: job median {job_s:.2f} s over {len(rows)} runs")
        for stage in rows[0][1]:
            print(f"  {stage:<18} {statistics.median(r[1].get(stage, 0) for r in rows):7.3f} s")
    on = results[True]
    share = statistics.median(r[1]["evaluation"] / r[0] for r in on)
    print(f"evaluation: median {100 * share:.1f}% of a job with realism on")
finally:
    server.terminate()
    server.wait()
