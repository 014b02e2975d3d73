#!/usr/bin/env python3
"""Usage: module-cycles.py CRATE_SRC_DIR...

Checks that no crate has an import circle between its module files: every path a
file names (`use` trees expanded, and `crate::`, `super::`, `self::` and child-module
paths in code) is resolved to the deepest module file that exists, and the strongly
connected components of that graph with more than one file are printed. Test modules
(from `#[cfg(test)] mod tests`) are left out. Exits 1 if any crate has a cycle."""
import os
import re
import sys


def module_files(root):
    files = {}
    for d, _, names in os.walk(root):
        for f in names:
            if f.endswith('.rs'):
                p = os.path.join(d, f)
                parts = os.path.relpath(p, root)[:-3].split(os.sep)
                if parts[-1] == 'mod':
                    parts = parts[:-1]
                if parts in (['lib'], ['main']):
                    parts = []
                files[tuple(parts)] = p
    return files


def expand(tree):
    """'a::{b, c::{d, e}}' -> ['a::b', 'a::c::d', 'a::c::e']"""
    tree = tree.strip()
    i = tree.find('{')
    if i < 0:
        return [re.sub(r'\s+as\s+\w+$', '', tree)]
    if '}' not in tree:
        return []
    head, body = tree[:i], tree[i + 1:tree.rindex('}')]
    items, depth, cur = [], 0, ''
    for ch in body:
        if ch == ',' and depth == 0:
            items.append(cur)
            cur = ''
            continue
        depth += ch == '{'
        depth -= ch == '}'
        cur += ch
    items.append(cur)
    out = []
    for it in (x.strip() for x in items):
        if it == 'self':
            out.append(head.rstrip(':'))
        elif it:
            out += [head + e for e in expand(it)]
    return out


def edges_of(files):
    def resolve(path):
        path = list(path)
        while path and tuple(path) not in files:
            path.pop()
        return tuple(path)

    edges = {m: set() for m in files}
    for m, p in files.items():
        src = open(p, encoding='utf-8').read()
        i = src.find('#[cfg(test)]\nmod tests')
        if i >= 0:
            src = src[:i]
        src = re.sub(r'//.*', '', src)
        is_dir = os.path.basename(p) in ('mod.rs', 'lib.rs', 'main.rs')
        here = list(m) if is_dir else list(m[:-1])
        children = set(re.findall(r'\bmod\s+(\w+)\s*;', src))
        paths = []
        for u in re.finditer(r'\buse\s+([^;]+);', src):
            paths += expand(u.group(1))
        paths += re.findall(r'(?<![\w:])((?:crate|super|self|\w+)::(?:\w+::)*\w+)', src)
        for path in paths:
            seg = [x for x in path.split('::') if x]
            if not seg:
                continue
            if seg[0] == 'crate':
                target = seg[1:]
            elif seg[0] == 'super':
                target = list(m[:-1]) + seg[1:]
            elif seg[0] == 'self':
                target = here + seg[1:]
            elif seg[0] in children:
                target = list(m) + seg
            else:
                continue
            r = resolve(target)
            if r != m and r != ():
                edges[m].add(r)
    return edges


def cycles(edges):
    index, low, stack, on, found, n = {}, {}, [], set(), [], [0]

    def strong(v):
        index[v] = low[v] = n[0]
        n[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            c = []
            while True:
                w = stack.pop()
                on.discard(w)
                c.append(w)
                if w == v:
                    break
            if len(c) > 1:
                found.append(sorted(c))

    sys.setrecursionlimit(10000)
    for v in edges:
        if v not in index:
            strong(v)
    return found


def main():
    bad = 0
    for root in sys.argv[1:]:
        edges = edges_of(module_files(root))
        found = cycles(edges)
        name = lambda m: '::'.join(m) or 'crate'
        for c in found:
            print(f'{root}: import circle between ' + ', '.join(name(x) for x in c))
            for a in c:
                for b in sorted(edges[a]):
                    if b in c:
                        print(f'    {name(a)} -> {name(b)}')
        print(f'{root}: {len(edges)} modules, {sum(len(e) for e in edges.values())} imports, {len(found)} circles')
        bad += len(found)
    sys.exit(1 if bad else 0)


if __name__ == '__main__':
    main()
