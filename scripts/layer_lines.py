#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
# Lines per layer (docs/DESIGN.md "Layers") and the longest functions, at one or more git revisions:
#   python3 scripts/layer_lines.py 1b1f2f9 HEAD
# Files are assigned to layers by name, so a revision from before the layer move (flat src/) is
# counted the same way as one after it. Function lengths: from a definition at column 0 to the
# next closing brace at column 0 (C++ and JavaScript), so nested functions count with their parent.
import subprocess, re, sys
def files(rev):
    out=subprocess.check_output(['git','ls-tree','-r','--name-only',rev],cwd='/work/main',text=True).split()
    return out
def content(rev,f):
    return subprocess.check_output(['git','show',f'{rev}:{f}'],cwd='/work/main',text=True,errors='replace')
CORE_PUB={'include/osteon/status.hpp','include/osteon/mesh.hpp','include/osteon/vec.hpp','include/osteon/codec.hpp'}
CORE_NAMES={'status.cpp','mesh.cpp','weld.cpp','weld.hpp','byte_io.hpp','entropy.cpp','entropy.hpp','corner_table.cpp','corner_table.hpp','edgebreaker_encode.cpp','edgebreaker_decode.cpp','edgebreaker_internal.hpp','quantize.cpp','parallelogram.cpp','normals.cpp','normals.hpp','codec_encode.cpp','codec_decode.cpp','codec_internal.hpp','connectivity.hpp','geometry.hpp','residual.hpp'}
TOOL_NAMES={'serve.cpp','phantom.cpp','segeval.cpp','segeval_internal.hpp','cut_discrepancy.cpp','serve.hpp','phantom.hpp','segeval.hpp'}
def layer(f):
    if 'node_modules' in f or f.endswith('package-lock.json'): return None
    name=f.split('/')[-1]
    if f.startswith('src/') or f.startswith('include/'):
        if f in CORE_PUB or f.startswith('src/core/') or f.startswith('src/codec/') or (f.count('/')==1 and f.startswith('src/') and name in CORE_NAMES): return 'core (src/core, src/codec, core headers)'
        if name in TOOL_NAMES: return 'tools (tools/, C++)'
        return 'library (src/, include/osteon)'
    if f.startswith('tools/'): return 'tools (tools/, C++)'
    if f.startswith('web/') and (f.endswith('.mjs') or f.endswith('.js') or f.endswith('.cpp') or f.endswith('.sh') or f.endswith('.html') or f.endswith('.css')):
        return 'web (viewer, decoder glue, their tests)'
    if f.startswith('bench/') and re.search(r'\.(cpp|hpp|mjs|js|sh)$',f): return 'bench'
    if f.startswith('tests/') and re.search(r'\.(cpp|hpp|sh)$',f): return 'tests (C++)'
    return None
def longest(rev,fs):
    res=[]
    for f in fs:
        if not re.search(r'\.(cpp|hpp|mjs|js)$',f) or 'node_modules' in f: continue
        if not (f.startswith('src/') or f.startswith('tools/') or f.startswith('web/viewer') or f.startswith('web/decoder') or f.startswith('include/')): continue
        lines=content(rev,f).split('\n')
        i=0
        while i<len(lines):
            l=lines[i]
            m=re.match(r'^(?:export )?(?:async )?function\*? ?(\w+)\s*\(',l) or re.match(r'^[A-Za-z][\w:<>,\s\*&]*?\b([\w:~]+)\(.*\)?\s*(const)?\s*\{?$',l)
            if m and not l.startswith(('namespace','struct','class','enum','using','static_assert','#','template','typedef')) and not l.endswith(';'):
                # find opening brace
                j=i
                while j<len(lines) and '{' not in lines[j]: j+=1
                k=j+1
                while k<len(lines) and not re.match(r'^\}',lines[k]): k+=1
                n=k-i+1
                if k<len(lines) and n>3: res.append((n,f,m.group(1)))
                i=k+1; continue
            i+=1
    res.sort(reverse=True)
    return res
for rev in sys.argv[1:]:
    fs=files(rev)
    tot={}
    for f in fs:
        L=layer(f)
        if L: tot[L]=tot.get(L,0)+content(rev,f).count('\n')
    print('==',rev)
    for k,v in sorted(tot.items()): print(f'  {k}: {v}')
    # JS nested functions: also count web render_worker startRenderer (nested indent)
    for n,f,name in longest(rev,fs)[:12]: print(f'  {n:4d} {f} {name}')
