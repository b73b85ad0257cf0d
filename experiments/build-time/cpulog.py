#!/usr/bin/env python3
"""Sums a cputime launcher log: total user+sys, by group, top N."""
import sys, collections
rows = {}
for line in open(sys.argv[1]):
    p = line.split()
    if len(p) < 4 or not p[0][0].isdigit(): continue
    rows[p[3]] = (float(p[0]) + float(p[1]), int(p[2]))
top = int(sys.argv[2]) if len(sys.argv) > 2 else 30
tot = sum(v[0] for v in rows.values())
print(f"compiles {len(rows)}  user+sys {tot:.0f} s ({tot/60:.1f} min)  max RSS {max(v[1] for v in rows.values())/1024:.0f} MB")
groups = collections.Counter()
for k, (t, m) in rows.items():
    parts = k.replace('CMakeFiles/', '').split('/')
    groups['/'.join(parts[:2]) if len(parts) > 2 else parts[0]] += t
for g, v in groups.most_common(30): print(f"  {v:7.1f}  {g}")
print("top:")
for k, (t, m) in sorted(rows.items(), key=lambda kv: -kv[1][0])[:top]: print(f"  {t:7.1f} {m/1024:6.0f}MB  {k}")
