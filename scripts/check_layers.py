#!/usr/bin/env python3
"""The layers' include rule: every `#include "..."` of the sources runs down the table of docs/ARCHITECTURE.md.

Usage: scripts/check_layers.py [SOURCE_DIR]   (default: the checkout this script is in)

The table (docs/ARCHITECTURE.md, "Who includes whom", between its two `layers` marker comments) is the one place
the rule is written: a row names a folder and the folders its files may include; a folder may include itself and,
transitively, whatever the folders it names may include. A file belongs to the longest folder of the table its path
starts with (nodes/plugins/ before nodes/), and so does an included path. Prints one line per include against the
table, `file:line: ...`, naming the rule, and exits 1; exits 0 when every include runs down the table. Run by CTest
(layers.includes).
"""
import os
import re
import sys

BEGIN = "<!-- layers: begin"
END = "<!-- layers: end -->"
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')
FOLDER = re.compile(r"`([a-z_/]+/)`")
EXTENSIONS = (".h", ".cpp")


def read_table(doc_path):
    """{folder: [folders it names]} from the doc's table; exits 2 when the table is missing or malformed."""
    with open(doc_path, encoding="utf-8") as f:
        text = f.read()
    begin, end = text.find(BEGIN), text.find(END)
    if begin < 0 or end < begin:
        sys.exit(f"check_layers: {doc_path} has no table between '{BEGIN} ...' and '{END}'")
    table = {}
    for line in text[begin:end].splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 2 or not cells[0].startswith("`"):
            continue  # the header, its rule and the markers
        folders = FOLDER.findall(cells[0])
        if len(folders) != 1:
            sys.exit(f"check_layers: a row of the table names {len(folders)} folders in its first cell: {line}")
        table[folders[0]] = FOLDER.findall(cells[1])
    if not table:
        sys.exit(f"check_layers: the table of {doc_path} has no rows")
    for folder, named in table.items():
        for n in named:
            if n not in table:
                sys.exit(f"check_layers: the row of {folder} names {n}, which has no row of its own")
    return table


def allowed_closure(table):
    """Per folder: itself, the folders it names, and what those may include."""
    closure = {}

    def visit(folder, path):
        if folder in closure:
            return closure[folder]
        if folder in path:
            sys.exit(f"check_layers: the table has a cycle: {' -> '.join(path + [folder])}")
        allowed = {folder}
        for n in table[folder]:
            allowed |= visit(n, path + [folder])
        closure[folder] = allowed
        return allowed

    for folder in table:
        visit(folder, [])
    return closure


def layer_of(path, folders):
    """The longest folder of the table `path` is in, or None."""
    best = None
    for folder in folders:
        if path.startswith(folder) and (best is None or len(folder) > len(best)):
            best = folder
    return best


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), ".."))
    doc = os.path.join(root, "docs", "ARCHITECTURE.md")
    table = read_table(doc)
    allowed = allowed_closure(table)
    tops = sorted({folder.split("/")[0] for folder in table})
    problems = []
    for top in tops:
        if not os.path.isdir(os.path.join(root, top)):
            problems.append(f"{top}/: a folder of the table that does not exist")
            continue
        for dirpath, dirnames, filenames in os.walk(os.path.join(root, top)):
            dirnames.sort()
            for name in sorted(filenames):
                if not name.endswith(EXTENSIONS):
                    continue
                full = os.path.join(dirpath, name)
                rel = os.path.relpath(full, root)
                layer = layer_of(rel, table)
                if layer is None:
                    problems.append(f"{rel}: in no folder of the table (docs/ARCHITECTURE.md, Who includes whom)")
                    continue
                with open(full, encoding="utf-8") as f:
                    for number, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        included = m.group(1)
                        target = layer_of(included, table)
                        if target is None:
                            problems.append(f"{rel}:{number}: includes \"{included}\", which is in no folder of the "
                                            "table (a project include is written from the top: \"core/error.h\")")
                        elif target not in allowed[layer]:
                            problems.append(f"{rel}:{number}: includes \"{included}\": {layer} may not include "
                                            f"{target} (it may include {', '.join(sorted(allowed[layer]))}; "
                                            "docs/ARCHITECTURE.md, Who includes whom)")
    for p in problems:
        print(p)
    if problems:
        print(f"check_layers: {len(problems)} include(s) against the layers")
        return 1
    print(f"check_layers: every include of {', '.join(t + '/' for t in tops)} runs down the layers")
    return 0


if __name__ == "__main__":
    sys.exit(main())
