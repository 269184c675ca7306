#!/usr/bin/env python3
"""fstcmp.py OLD.fst NEW.fst: the two FSTs' decoded changes (fst2vcd -e) per variable, equal
once the old file's 128-bit ASCII states are decoded and the new file's enum-table states are
named through their table. Prints a summary; exit 1 on any difference."""
import subprocess, sys

def changes(path):
    text = subprocess.run(["fst2vcd", "-e", path], capture_output=True, text=True, check=True).stdout
    scope, ids, tables, pending, out, t = [], {}, {}, None, {}, 0
    for line in text.splitlines():
        tok = line.split()
        if not tok:
            continue
        if tok[0] == "$scope":
            scope.append(tok[2])
        elif tok[0] == "$upscope":
            scope.pop()
        elif tok[0] == "$attrbegin" and tok[1:3] == ["misc", "07"]:
            h = int(tok[-2])
            if tok[3] == '""':
                pending = h
            else:
                n = int(tok[4])
                tables[h] = dict(zip(tok[5 + n:5 + 2 * n], tok[5:5 + n]))
        elif tok[0] == "$var":
            ids[tok[3]] = (".".join(scope + [tok[4].split("[")[0]]), int(tok[2]), pending)
            pending = None
        elif tok[0].startswith("#"):
            t = int(tok[0][1:])
        elif tok[0][0] == "b" and len(tok) == 2 and tok[1] in ids:
            name, w, tab = ids[tok[1]]
            bits = tok[0][1:].rjust(w, "0")
            if "x" in bits:
                continue
            if tab is not None:
                v = tables[tab][bits]
            elif w == 128:
                v = "".join(chr(int(bits[i:i + 8], 2)) for i in range(0, 128, 8)).lstrip("\0")
            else:
                v = bits.lstrip("0") or "0"
            out.setdefault(name, []).append((t, v))
        elif tok[0][0] in "01" and tok[0][1:] in ids:
            out.setdefault(ids[tok[0][1:]][0], []).append((t, tok[0][0]))
    return out

a, b = changes(sys.argv[1]), changes(sys.argv[2])
n = sum(len(v) for v in a.values())
states = sum(len(v) for k, v in a.items() if k.endswith(".state"))
same = a == b
print(f"{sys.argv[1]} vs {sys.argv[2]}: {len(a)} vs {len(b)} variables, {n} changes ({states} of FSM states): {'identical' if same else 'DIFFERENT'}")
if not same:
    for k in sorted(set(a) | set(b)):
        if a.get(k) != b.get(k):
            print("  differs:", k); break
sys.exit(0 if same else 1)
