"""Runs the groundscope study in STUDY on a Ray cluster: one task per run, each with num_cpus
equal to its training threads. Written by `groundscope study plan`.

    python ray_driver.py [--address ADDRESS]      # default: a local cluster

(with the groundscope package: groundscope.study.run_ray(STUDY, address=...)). Each task runs
its line of commands.txt (`groundscope study exec STUDY NAME`); the results stay in the study
directory, so `groundscope study collect STUDY` reads them as it reads a local run's.
"""
import argparse
import json
import subprocess
import sys

import ray

STUDY = "@STUDY@"


@ray.remote
def run(binary, study, name):
    done = subprocess.run([binary, "study", "exec", study, name])
    return name, done.returncode


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--address", default=None)
    args = ap.parse_args()
    ray.init(address=args.address)
    with open(STUDY + "/manifest.json") as f:
        manifest = json.load(f)
    tasks = [
        run.options(num_cpus=r["threads"]).remote(manifest["binary"], STUDY, r["name"])
        for r in manifest["runs"]
    ]
    failed = [(n, rc) for n, rc in ray.get(tasks) if rc != 0]
    for n, rc in failed:
        print(f"run {n} failed (exit {rc}): see {STUDY}/runs/{n}/study.log", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
