#!/usr/bin/env python3
"""IKChain's class reference (godot_project/addons/ikchain/doc_classes/*.xml): checked and embedded.

  class_docs.py embed OUT.hpp EXTENSION_API.json XML...
      Run by the build. Checks every XML file (below), then writes a header holding each file's
      bytes, which src/godot/editor_help.cpp hands to the editor help at EDITOR initialization
      (the library never reads the XML from disk).
  class_docs.py check-api GODOT_BINARY PROJECT_DIR
      Compares the XML with the classes the built library really registers: runs Godot's own
      `--doctool --gdextension-docs` on a copy of the project (the same tool godot-cpp projects use
      to write their doc_classes), seeded with our XML so it merges our text in, and reports every
      property, method, constant, signal or enum that is registered but undocumented, documented
      but not registered, or documented with another type, default, setter, getter or value.
  class_docs.py update GODOT_BINARY PROJECT_DIR
      Same run, then copies Godot's merged files back over ours: signatures, defaults and new
      entries come from the library, descriptions stay ours. Review the diff; fill in new entries.

The `embed` check, per file: well-formed, one <class> whose name is the file name, inheriting an
engine class or one of ours; every brief, description, member, method, constant and signal has
text; no name twice; members and methods sorted by name (as Godot writes them, so `update` diffs
stay small); each enum's values distinct; a member's `enum="Class.Enum"` names an enum declared
there; every BBCode reference ([Class], [member x], [method C.x], [constant X], [enum E],
[signal s], [param p]) resolves, against our XML files and extension_api.json (walking `inherits`).
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

ADDON_REL = os.path.join("addons", "ikchain")
FORMATTING_TAGS = {
    "b", "i", "u", "s", "code", "codeblock", "codeblocks", "gdscript", "csharp", "kbd", "br", "lb",
    "rb", "center", "url", "img", "color", "font", "indent", "ul", "ol",
}


class Api:
    """What a reference may point at: engine classes (extension_api.json) plus our XML classes."""

    def __init__(self, api_json):
        self.classes = {}  # name -> {"inherits", "member", "method", "constant", "enum", "signal"}
        for c in api_json["classes"]:
            consts = {k["name"] for k in c.get("constants", [])}
            enums = set()
            for e in c.get("enums", []):
                enums.add(e["name"])
                consts |= {v["name"] for v in e["values"]}
            self.classes[c["name"]] = {
                "inherits": c.get("inherits"),
                "member": {p["name"] for p in c.get("properties", [])},
                "method": {m["name"] for m in c.get("methods", [])},
                "constant": consts,
                "enum": enums,
                "signal": {s["name"] for s in c.get("signals", [])},
            }
        for b in api_json["builtin_classes"]:
            self.classes[b["name"]] = {
                "inherits": None,
                "member": {m["name"] for m in b.get("members", [])},
                "method": {m["name"] for m in b.get("methods", [])},
                "constant": {k["name"] for k in b.get("constants", [])},
                "enum": {e["name"] for e in b.get("enums", [])},
                "signal": set(),
            }

    def add_doc(self, root):
        entry = {"inherits": root.get("inherits"), "member": set(), "method": set(), "constant": set(),
                 "enum": set(), "signal": set()}
        for m in root.iter("member"):
            entry["member"].add(m.get("name"))
        for m in root.iter("method"):
            entry["method"].add(m.get("name"))
        for s in root.iter("signal"):
            entry["signal"].add(s.get("name"))
        for k in root.iter("constant"):
            entry["constant"].add(k.get("name"))
            if k.get("enum"):
                entry["enum"].add(k.get("enum"))
        self.classes[root.get("name")] = entry

    def has(self, cls, kind, name):
        seen = set()
        while cls and cls not in seen:
            seen.add(cls)
            c = self.classes.get(cls)
            if c is None:
                return False
            if name in c[kind]:
                return True
            cls = c["inherits"]
        return False


def text_of(el):
    return (el.text or "").strip() if el is not None else ""


def check_file(path, root, api, errors):
    name = os.path.splitext(os.path.basename(path))[0]

    def err(msg):
        errors.append("%s: %s" % (path, msg))

    if root.tag != "class" or root.get("name") != name:
        err("the root element must be <class name=\"%s\">" % name)
        return
    if root.get("inherits") not in api.classes:
        err("inherits=\"%s\" is not a Godot class nor one of ours" % root.get("inherits"))
    for tag in ("brief_description", "description"):
        if not text_of(root.find(tag)):
            err("<%s> is empty" % tag)

    def unique_sorted(section, tag, sort):
        els = root.findall("%s/%s" % (section, tag))
        names = [e.get("name") for e in els]
        for n in sorted({n for n in names if names.count(n) > 1}):
            err("%s \"%s\" documented twice" % (tag, n))
        if sort and names != sorted(names):
            err("<%s> not sorted by name (Godot writes them sorted): %s" % (section, ", ".join(names)))
        for e in els:
            desc = e.find("description") if tag in ("method", "signal") else e
            if not text_of(desc):
                err("%s \"%s\" has no description" % (tag, e.get("name")))
        return els

    members = unique_sorted("members", "member", True)
    methods = unique_sorted("methods", "method", True)
    unique_sorted("signals", "signal", True)
    constants = unique_sorted("constants", "constant", False)

    for m in members:
        for attr in ("type", "default", "setter", "getter"):
            if not m.get(attr):
                err("member \"%s\" lacks %s=\"...\"" % (m.get("name"), attr))
        enum = m.get("enum")
        if enum:
            cls, _, ename = enum.rpartition(".")
            if not api.has(cls or name, "enum", ename):
                err("member \"%s\": enum=\"%s\" is not declared" % (m.get("name"), enum))
    for m in methods:
        if m.find("return") is None or not m.find("return").get("type"):
            err("method \"%s\" lacks <return type=\"...\"/>" % m.get("name"))
    values = {}
    for k in constants:
        if not re.fullmatch(r"-?\d+", k.get("value") or ""):
            err("constant \"%s\" has no integer value" % k.get("name"))
            continue
        key = (k.get("enum") or "", int(k.get("value")))
        if key in values:
            err("constants \"%s\" and \"%s\" share the value %s in enum %s" %
                (values[key], k.get("name"), key[1], key[0] or "(none)"))
        values[key] = k.get("name")

    # Every text of the file, with the element it documents (for [param]).
    params_of = {}
    for m in root.iter("method"):
        params_of[id(m)] = {p.get("name") for p in m.findall("param")}
    texts = []
    for el in root.iter():
        owner_params = set()
        if el.tag == "description":
            for m in root.iter("method"):
                if el in list(m):
                    owner_params = params_of[id(m)]
        if el.text and el.text.strip():
            texts.append((el.text, owner_params))
    for text, params in texts:
        text = re.sub(r"\[codeblocks?\].*?\[/codeblocks?\]", "", text, flags=re.S)  # code, not BBCode
        for tag in re.findall(r"\[([^\]\[]+)\]", text):
            word = tag.split(" ", 1)
            head = word[0].lstrip("/").split("=", 1)[0]
            if head in FORMATTING_TAGS:
                continue
            if len(word) == 2 and head in ("member", "method", "constant", "enum", "signal"):
                ref = word[1].strip()
                cls, _, item = ref.rpartition(".")
                if not api.has(cls or name, head, item):
                    err("[%s %s] does not resolve (no %s \"%s\" in %s)" % (head, ref, head, item, cls or name))
            elif len(word) == 2 and head == "param":
                if word[1].strip() not in params:
                    err("[param %s] is not a parameter of the method it documents" % word[1].strip())
            elif len(word) == 1 and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", head):
                if head not in api.classes:
                    err("[%s] is not a class" % head)
            else:
                err("unknown BBCode tag [%s]" % tag)


def load_docs(paths, api_path):
    with open(api_path, encoding="utf-8") as f:
        api = Api(json.load(f))
    errors, roots = [], {}
    for p in paths:
        try:
            roots[p] = ET.parse(p).getroot()
        except ET.ParseError as e:
            errors.append("%s: not well-formed XML: %s" % (p, e))
    for root in roots.values():
        if root.tag == "class" and root.get("name"):
            api.add_doc(root)
    for p, root in roots.items():
        check_file(p, root, api, errors)
    return roots, errors


def embed(out_path, api_path, paths):
    paths = sorted(paths)
    if not paths:
        sys.exit("class_docs: error: no XML files given")
    _, errors = load_docs(paths, api_path)
    if errors:
        sys.stderr.write("class_docs: the class reference has %d problem(s):\n  %s\n" %
                         (len(errors), "\n  ".join(errors)))
        sys.exit(1)
    lines = [
        "// Generated by tools/class_docs.py from godot_project/addons/ikchain/doc_classes/*.xml. Do not edit.",
        "#pragma once",
        "",
        "#include <cstddef>",
        "",
        "namespace ikchain::godot::class_docs {",
        "",
        "struct ClassDoc {",
        "  const char* class_name;",
        "  const char* xml;  // UTF-8, not NUL-terminated: use size",
        "  std::size_t size;",
        "};",
        "",
    ]
    entries = []
    for p in paths:
        data = open(p, "rb").read()
        data.decode("utf-8")  # fails loudly on a non-UTF-8 file
        cls = os.path.splitext(os.path.basename(p))[0]
        var = "k%sXml" % re.sub(r"\W", "_", cls)
        lines.append("inline constexpr char %s[] = {" % var)
        for i in range(0, len(data), 24):
            lines.append("    " + ", ".join("'\\x%02x'" % b for b in data[i:i + 24]) + ",")
        lines.append("};")
        lines.append("")
        entries.append('    {"%s", %s, sizeof(%s)},' % (cls, var, var))
    lines.append("inline constexpr ClassDoc kClassDocs[] = {")
    lines += entries
    lines.append("};")
    lines.append("")
    lines.append("}  // namespace ikchain::godot::class_docs")
    with open(out_path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


# ------------------------------------------------------------------ against the real library

def run_doctool(godot, project_dir, work):
    """Godot's doctool on a copy of the project, seeded with our XML; returns its output dir."""
    proj = os.path.join(work, "project")
    shutil.copytree(project_dir, proj, ignore=shutil.ignore_patterns(".godot"))
    os.makedirs(os.path.join(proj, ".godot"))
    with open(os.path.join(proj, ".godot", "extension_list.cfg"), "w") as f:
        f.write("res://addons/ikchain/ikchain.gdextension\n")
    out = os.path.join(work, "out")
    ours = os.path.join(project_dir, ADDON_REL, "doc_classes")
    shutil.copytree(ours, os.path.join(out, "doc_classes"))
    env = dict(os.environ)
    for var in ("XDG_CONFIG_HOME", "XDG_CACHE_HOME", "XDG_DATA_HOME"):
        env[var] = os.path.join(work, "xdg")
    cmd = [godot, "--headless", "--path", proj, "--doctool", out, "--gdextension-docs"]
    r = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    if r.returncode != 0 or not os.path.isdir(os.path.join(out, "doc_classes")):
        sys.exit("class_docs: `%s` failed (exit %d):\n%s" % (" ".join(cmd), r.returncode, r.stdout[-3000:]))
    return os.path.join(out, "doc_classes")


def entries(root):
    """(kind, name) -> attributes + description, for one class file."""
    out = {}
    for m in root.findall("members/member"):
        out[("member", m.get("name"))] = dict(m.attrib, _text=text_of(m))
    for m in root.findall("methods/method"):
        ret = m.find("return")
        sig = "%s(%s)%s" % (ret.get("type") if ret is not None else "void",
                            ", ".join("%s: %s" % (p.get("name"), p.get("type")) for p in m.findall("param")),
                            " " + m.get("qualifiers") if m.get("qualifiers") else "")
        out[("method", m.get("name"))] = {"signature": sig, "_text": text_of(m.find("description"))}
    for s in root.findall("signals/signal"):
        out[("signal", s.get("name"))] = {"_text": text_of(s.find("description"))}
    for k in root.findall("constants/constant"):
        out[("constant", k.get("name"))] = dict(k.attrib, _text=text_of(k))
    return out


def compare(ours_dir, godots_dir):
    problems = []
    ours_files = {f for f in os.listdir(ours_dir) if f.endswith(".xml")}
    godots_files = {f for f in os.listdir(godots_dir) if f.endswith(".xml")}
    for f in sorted(godots_files - ours_files):
        problems.append("class %s is registered but has no doc_classes/%s" % (f[:-4], f))
    for f in sorted(ours_files - godots_files):
        problems.append("doc_classes/%s documents a class the library does not register" % f)
    for f in sorted(ours_files & godots_files):
        cls = f[:-4]
        mine = entries(ET.parse(os.path.join(ours_dir, f)).getroot())
        real_root = ET.parse(os.path.join(godots_dir, f)).getroot()
        mine_root = ET.parse(os.path.join(ours_dir, f)).getroot()
        if real_root.get("inherits") != mine_root.get("inherits"):
            problems.append("%s inherits %s, documented as %s" %
                            (cls, real_root.get("inherits"), mine_root.get("inherits")))
        real = entries(real_root)
        for key in sorted(set(real) - set(mine)):
            problems.append("%s: %s %s is registered but not documented" % (cls, key[0], key[1]))
        for key in sorted(set(mine) - set(real)):
            problems.append("%s: %s %s is documented but not registered" % (cls, key[0], key[1]))
        for key in sorted(set(mine) & set(real)):
            for attr in sorted((set(mine[key]) | set(real[key])) - {"_text"}):
                a, b = mine[key].get(attr), real[key].get(attr)
                if a != b:
                    problems.append("%s: %s %s: %s is %r in the library, %r in the XML" %
                                    (cls, key[0], key[1], attr, b, a))
    return problems


def check_api(godot, project_dir, update=False):
    ours = os.path.join(project_dir, ADDON_REL, "doc_classes")
    with tempfile.TemporaryDirectory(prefix="ikchain-docs-") as work:
        godots = run_doctool(godot, project_dir, work)
        problems = compare(ours, godots)
        if update:
            for f in sorted(os.listdir(godots)):
                if f.endswith(".xml"):
                    shutil.copyfile(os.path.join(godots, f), os.path.join(ours, f))
            print("class_docs: %s rewritten from the library's registration (%d difference(s) before)" %
                  (ours, len(problems)))
            return 0
    if problems:
        print("class_docs: the class reference and the library disagree (%d):" % len(problems))
        for p in problems:
            print("  " + p)
        print("Fix the XML (or run `tools/class_docs.py update ...` and review the diff).")
        return 1
    print("class_docs: the class reference matches the library's registration")
    return 0


def main(argv):
    if len(argv) >= 4 and argv[1] == "embed":
        embed(argv[2], argv[3], argv[4:])
        return 0
    if len(argv) == 4 and argv[1] in ("check-api", "update"):
        return check_api(argv[2], argv[3], update=argv[1] == "update")
    sys.stderr.write(__doc__)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
