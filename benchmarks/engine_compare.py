#!/usr/bin/env python3
"""Engine overhead of two modalflow builds, as a ratio: the 200-stage
pipeline of benchmarks/engine.rs, fully cached `run`, both binaries
interleaved round by round (the machine is shared), best wall time and
median child CPU time per binary.

    python3 benchmarks/engine_compare.py BEFORE_BINARY AFTER_BINARY [ROUNDS]
"""
import os, subprocess, sys, time, resource, tempfile, statistics, shutil
def pipeline():
    y="name: bench200\nstages:\n"
    def stage(name,deps,out):
        dy = "" if not deps else ", deps: [%s]"%", ".join(deps)
        cat = "echo seed" if not deps else "cat "+" ".join(deps)
        return f'  {name}:\n    kind: command\n    params: {{cmd: "{cat} > {out}; echo {name} >> {out}"{dy}, outs: [{out}]}}\n'
    for g in range(20):
        src=f"g{g}_src.txt"; y+=stage(f"g{g}_src",[],src); prev=src
        for c in range(4):
            out=f"g{g}_c{c}.txt"; y+=stage(f"g{g}_c{c}",[prev],out); prev=out
        fans=[]
        for f in range(4):
            out=f"g{g}_f{f}.txt"; y+=stage(f"g{g}_f{f}",[prev],out); fans.append(out)
        y+=stage(f"g{g}_join",fans,f"g{g}_join.txt")
    return y
bins=sys.argv[1:3]; n=int(sys.argv[3]) if len(sys.argv)>3 else 15
dirs=[]
for b in bins:
    d=tempfile.mkdtemp(prefix="modalflow-cmp-"); open(d+"/p.yaml","w").write(pipeline()); dirs.append(d)
    subprocess.run([b,"run","p.yaml","--progress","none"],cwd=d,check=True,capture_output=True)
wall={b:[] for b in bins}; cpu={b:[] for b in bins}
for i in range(n):
    for b,d in zip(bins,dirs):
        r0=resource.getrusage(resource.RUSAGE_CHILDREN); t=time.perf_counter()
        subprocess.run([b,"run","p.yaml","--progress","none"],cwd=d,check=True,capture_output=True)
        w=time.perf_counter()-t; r1=resource.getrusage(resource.RUSAGE_CHILDREN)
        wall[b].append(w*1e3); cpu[b].append((r1.ru_utime+r1.ru_stime-r0.ru_utime-r0.ru_stime)*1e3)
for b in bins:
    print(f"{b}: wall best {min(wall[b]):.1f} ms median {statistics.median(wall[b]):.1f}; cpu median {statistics.median(cpu[b]):.1f} ms min {min(cpu[b]):.1f}")
a,b=bins
print(f"ratio after/before: wall best {min(wall[b])/min(wall[a]):.2f}, cpu median {statistics.median(cpu[b])/statistics.median(cpu[a]):.2f}")
for d in dirs:
    shutil.rmtree(d, ignore_errors=True)
