"""Runs the ```python blocks of a Markdown file (docs/PYTHON.md) in order, in one namespace,
like one interactive session, in a scratch working directory. Exits 1 naming the first block
that fails. Usage: run_doc_examples.py DOC.md [WORKDIR]
"""
import os
import re
import sys
import tempfile
import traceback


def blocks(text):
    """(line number, code) of every ```python block."""
    for m in re.finditer(r"^```python\n(.*?)^```", text, re.S | re.M):
        yield text.count("\n", 0, m.start()) + 2, m.group(1)


def main():
    doc = os.path.abspath(sys.argv[1])
    with open(doc) as f:
        found = list(blocks(f.read()))
    if not found:
        print(f"{doc}: no python blocks", file=sys.stderr)
        return 1
    workdir = sys.argv[2] if len(sys.argv) > 2 else tempfile.mkdtemp(prefix="gvd-doc-")
    os.makedirs(workdir, exist_ok=True)
    os.chdir(workdir)
    namespace = {"__name__": "__main__"}
    for line, code in found:
        try:
            exec(compile(code, f"{doc}:{line}", "exec"), namespace)
        except BaseException:
            traceback.print_exc()
            print(f"FAIL: the example at {doc}:{line}", file=sys.stderr)
            return 1
        print(f"ok   the example at line {line}")
    print(f"{len(found)} examples of {doc} ran")
    return 0


if __name__ == "__main__":
    sys.exit(main())
