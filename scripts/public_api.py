#!/usr/bin/env python3
"""The public API of the library crates as a listing, one item per line, so that a change to
it is a reviewed diff (issue 33 item 5).

    scripts/public_api.py            # writes docs/public-api/<crate>.txt
    scripts/public_api.py --check    # fails when a listing in the repository differs

It reads rustdoc's JSON output of each crate (built with the pinned toolchain: the JSON format
is an unstable rustdoc output, enabled here with RUSTC_BOOTSTRAP=1, and its format version is
checked) and walks the crate from its root as a user of the crate can: public modules, public
re-exports (a glob re-export lists the items it brings), and of every public type its public
fields, enum variants, the public functions and constants of its inherent impls, and the items
of public traits. Trait implementations are not listed (derives and `From` impls would drown
the listing). A line is `kind path`, e.g. `fn canopen_drive::Drive::tick`.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CRATES = ["canopen-drive"]
LISTINGS = os.path.join(ROOT, "docs", "public-api")
# rustdoc's JSON format of the pinned toolchain (rust-toolchain.toml); another version may
# name things differently, so the walk refuses it rather than list something else.
FORMAT_VERSIONS = {57}


def rustdoc_json(crate, target_dir):
    """Builds the crate's rustdoc JSON (default features) and returns it parsed."""
    env = dict(os.environ)
    env["RUSTC_BOOTSTRAP"] = "1"
    env["RUSTDOCFLAGS"] = "-Z unstable-options --output-format json"
    subprocess.run(
        ["cargo", "doc", "-q", "--no-deps", "-p", crate, "--target-dir", target_dir],
        cwd=ROOT,
        env=env,
        check=True,
    )
    path = os.path.join(target_dir, "doc", crate.replace("-", "_") + ".json")
    with open(path) as f:
        doc = json.load(f)
    if doc.get("format_version") not in FORMAT_VERSIONS:
        sys.exit(f"public_api.py: rustdoc JSON format {doc.get('format_version')}, expected one of {FORMAT_VERSIONS}")
    return doc


class Walk:
    def __init__(self, doc):
        self.index = doc["index"]
        self.crate_id = self.index[str(doc["root"])]["crate_id"]
        self.lines = set()
        self.ids = set()
        self.seen_modules = set()

    def item(self, item_id):
        return self.index.get(str(item_id))

    def add(self, kind, path, item_id):
        self.lines.add(f"{kind} {'::'.join(path)}")
        self.ids.add(item_id)

    def module(self, module_id, path):
        key = (module_id, tuple(path))
        if key in self.seen_modules:
            return
        self.seen_modules.add(key)
        module = self.item(module_id)
        for child in module["inner"]["module"]["items"]:
            self.visit(child, path, in_module=True)

    def visit(self, item_id, path, in_module=False, name=None):
        item = self.item(item_id)
        if item is None or item["crate_id"] != self.crate_id:
            return  # another crate's item (a re-export of a dependency's type is not walked)
        if in_module and item["visibility"] != "public":
            return
        (kind, inner), = item["inner"].items()
        name = name or item["name"]
        if kind == "use":
            use = inner
            if use["id"] is None:
                return
            target = self.item(use["id"])
            if target is None:
                return
            if use["is_glob"]:
                # The items of the module (or the variants of the enum) it brings.
                (target_kind, target_inner), = target["inner"].items()
                if target_kind == "module":
                    for child in target_inner["items"]:
                        self.visit(child, path, in_module=True)
                return
            self.visit(use["id"], path, name=use["name"])
            return
        here = path + [name]
        if kind == "module":
            self.add("mod", here, item_id)
            self.module(item_id, here)
        elif kind in ("struct", "enum", "union"):
            self.add(kind, here, item_id)
            if kind == "struct":
                fields = inner["kind"].get("plain", {}).get("fields", []) if isinstance(inner["kind"], dict) else []
                for field in fields:
                    f = self.item(field)
                    if f and f["visibility"] == "public":
                        self.add("field", here + [f["name"]], field)
            if kind == "enum":
                for variant in inner["variants"]:
                    v = self.item(variant)
                    if v:
                        self.add("variant", here + [v["name"]], variant)
            self.impls(inner.get("impls", []), here)
        elif kind == "trait":
            self.add("trait", here, item_id)
            for member in inner["items"]:
                m = self.item(member)
                if m:
                    (member_kind, _), = m["inner"].items()
                    self.add(f"trait {member_kind}", here + [m["name"]], member)
        elif kind in ("function", "constant", "static", "type_alias", "macro", "proc_macro", "trait_alias"):
            self.add({"function": "fn", "constant": "const", "type_alias": "type"}.get(kind, kind), here, item_id)
        else:
            self.add(kind, here, item_id)

    def impls(self, impl_ids, path):
        for impl_id in impl_ids:
            impl = self.item(impl_id)
            if impl is None:
                continue
            inner = impl["inner"]["impl"]
            if inner["trait"] is not None or inner.get("is_synthetic") or inner.get("blanket_impl"):
                continue
            for member in inner["items"]:
                m = self.item(member)
                if m is None or m["visibility"] != "public":
                    continue
                (member_kind, _), = m["inner"].items()
                kind = {"function": "fn", "constant": "const", "type_alias": "type"}.get(member_kind, member_kind)
                self.add(kind, path + [m["name"]], member)


def listing(crate, target_dir):
    doc = rustdoc_json(crate, target_dir)
    walk = Walk(doc)
    root = doc["root"]
    walk.module(root, [doc["index"][str(root)]["name"]])
    return sorted(walk.lines), len(walk.ids)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="fail when a listing differs")
    args = parser.parse_args()
    target_dir = os.environ.get("PUBLIC_API_TARGET_DIR") or tempfile.mkdtemp(prefix="public-api-")
    os.makedirs(LISTINGS, exist_ok=True)
    failed = False
    for crate in CRATES:
        lines, items = listing(crate, target_dir)
        text = "".join(line + "\n" for line in lines)
        path = os.path.join(LISTINGS, crate + ".txt")
        old = open(path).read() if os.path.exists(path) else None
        print(f"{crate}: {items} public items under {len(lines)} paths")
        if args.check:
            if old != text:
                old_lines = set((old or "").splitlines())
                added = [line for line in lines if line not in old_lines]
                removed = [line for line in sorted(old_lines) if line not in set(lines)]
                print(f"{path} differs from the crate: {len(added)} items added, {len(removed)} removed")
                for line in added[:40]:
                    print(f"  + {line}")
                for line in removed[:40]:
                    print(f"  - {line}")
                print("run scripts/public_api.py to write it, and review the diff")
                failed = True
        else:
            with open(path, "w") as f:
                f.write(text)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
