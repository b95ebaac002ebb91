#!/usr/bin/env python3
"""Which modules of src/cmd use which (`super::NAME`), and any circle among them (issue 60:
none). Run from the repository root: python3 .ci/cmd_imports.py"""
import re, os, sys
mods = {f[:-3] for f in os.listdir('src/cmd') if f.endswith('.rs')}
g = {}
for m in mods:
    s = open(f'src/cmd/{m}.rs').read()
    g[m] = sorted({d for d in re.findall(r'super::(\w+)', s) if d in mods and d != m})
# find cycles via DFS
cycles = []
def dfs(n, path, seen):
    for d in g[n]:
        if d in path:
            c = path[path.index(d):] + [d]
            cycles.append(' -> '.join(c))
        elif d not in seen:
            seen.add(d); dfs(d, path + [d], seen)
for m in sorted(mods):
    dfs(m, [m], {m})
print('\n'.join(sorted(set(cycles))) or 'no cycle in src/cmd')
for m in sorted(g): print(f'{m} -> {" ".join(g[m])}')
