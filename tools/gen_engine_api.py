#!/usr/bin/env python3
"""Generates engine_api.gen.hpp from Godot's dumped extension_api.json.

Reads a list of the engine entities the extension uses (src/godot/engine_api.txt) and emits, for
each, the identifiers Godot needs to resolve it at run time: method hashes, virtual hashes, builtin
constructor indices, enum values and builtin sizes. Hashes never get typed by hand: if the engine
we build against lacks an entry (or changed its signature), the build stops here naming it.

List format (one entry a line, '#' starts a comment):
  method      Class method_name          engine class method, called by ptrcall
  virtual     Class _virtual_name        virtual we override; its hash is checked at dispatch
  builtin     Builtin method_name        method of a builtin (Variant) type
  constructor Builtin ArgType,ArgType    builtin constructor by argument types ('-' for none)
  enum        EnumName                   a global enum's values (e.g. PropertyHint)
  constant    Class NAME                 an engine class's integer constant (e.g. notifications)
  size        Builtin                    builtin size for the engine's build configuration
"""
import json
import sys


def fail(msg):
    sys.stderr.write("gen_engine_api: error: %s\n" % msg)
    sys.exit(1)


def ident(s):
    return "".join(c if c.isalnum() else "_" for c in s)


def main(argv):
    if len(argv) != 4:
        fail("usage: gen_engine_api.py extension_api.json engine_api.txt out.hpp")
    api_path, list_path, out_path = argv[1:]
    with open(api_path) as f:
        api = json.load(f)

    header = api["header"]
    # "float_64" = single-precision real_t on a 64-bit build; "double_64" = real_t is double.
    precision = "float" if header.get("precision", "single") == "single" else "double"
    config = "%s_64" % precision
    sizes = None
    for entry in api["builtin_class_sizes"]:
        if entry["build_configuration"] == config:
            sizes = {s["name"]: s["size"] for s in entry["sizes"]}
    if sizes is None:
        fail("extension_api.json has no builtin_class_sizes for configuration %s" % config)

    classes = {c["name"]: c for c in api["classes"]}
    builtins = {c["name"]: c for c in api["builtin_classes"]}
    enums = {e["name"]: e for e in api["global_enums"]}

    methods, virtuals, bmethods, ctors, enum_lines, size_lines, const_lines = [], [], [], [], [], [], []
    errors = []

    def find_class_method(cls, name):
        # Walk up the inheritance chain: a method may be declared on a base class.
        c = cls
        while c is not None:
            if c not in classes:
                return None, None
            for m in classes[c].get("methods", []):
                if m["name"] == name:
                    return c, m
            c = classes[c].get("inherits")
        return None, None

    with open(list_path) as f:
        for lineno, raw in enumerate(f, 1):
            line = raw.split("#", 1)[0].strip()
            if not line:
                continue
            parts = line.split()
            kind = parts[0]
            where = "%s:%d" % (list_path, lineno)
            if kind in ("method", "virtual"):
                if len(parts) != 3:
                    errors.append("%s: expected '%s Class method'" % (where, kind))
                    continue
                cls, name = parts[1], parts[2]
                if cls not in classes:
                    errors.append("%s: class %s not found in extension_api.json" % (where, cls))
                    continue
                owner, m = find_class_method(cls, name)
                if m is None or "hash" not in m:
                    errors.append("%s: method %s.%s (or its hash) not found in extension_api.json"
                                  % (where, cls, name))
                    continue
                if kind == "virtual" and not m.get("is_virtual"):
                    errors.append("%s: %s.%s is not virtual" % (where, cls, name))
                    continue
                if kind == "method" and m.get("is_virtual"):
                    errors.append("%s: %s.%s is virtual; list it as 'virtual'" % (where, cls, name))
                    continue
                (virtuals if kind == "virtual" else methods).append((owner, name, m["hash"]))
            elif kind == "builtin":
                if len(parts) != 3:
                    errors.append("%s: expected 'builtin Type method'" % where)
                    continue
                t, name = parts[1], parts[2]
                found = [m for m in builtins.get(t, {}).get("methods", []) if m["name"] == name]
                if not found:
                    errors.append("%s: builtin method %s.%s not found in extension_api.json"
                                  % (where, t, name))
                    continue
                bmethods.append((t, name, found[0]["hash"]))
            elif kind == "constructor":
                if len(parts) != 3:
                    errors.append("%s: expected 'constructor Type Arg,Arg'" % where)
                    continue
                t, args = parts[1], ([] if parts[2] == "-" else parts[2].split(","))
                if t not in builtins:
                    errors.append("%s: builtin type %s not found" % (where, t))
                    continue
                found = [c for c in builtins[t]["constructors"]
                         if [a["type"] for a in c.get("arguments", [])] == args]
                if not found:
                    errors.append("%s: constructor %s(%s) not found" % (where, t, ", ".join(args)))
                    continue
                ctors.append((t, args, found[0]["index"]))
            elif kind == "enum":
                name = parts[1]
                if name not in enums:
                    errors.append("%s: global enum %s not found" % (where, name))
                    continue
                enum_lines.append((name, [(v["name"], v["value"]) for v in enums[name]["values"]]))
            elif kind == "constant":
                if len(parts) != 3:
                    errors.append("%s: expected 'constant Class NAME'" % where)
                    continue
                cls, name = parts[1], parts[2]
                found = [k for k in classes.get(cls, {}).get("constants", []) if k["name"] == name]
                if not found:
                    errors.append("%s: constant %s.%s not found in extension_api.json" % (where, cls, name))
                    continue
                const_lines.append((cls, name, found[0]["value"]))
            elif kind == "size":
                t = parts[1]
                if t not in sizes:
                    errors.append("%s: no size for builtin %s" % (where, t))
                    continue
                size_lines.append((t, sizes[t]))
            else:
                errors.append("%s: unknown entry kind '%s'" % (where, kind))
    if errors:
        fail("the engine API does not match what IKChain needs:\n  " + "\n  ".join(errors))

    out = []
    w = out.append
    w("// Generated by tools/gen_engine_api.py from %s. Do not edit." % header["version_full_name"])
    w("// Build configuration: %s (real_t = %s, 64-bit pointers)." % (config, precision))
    w("#pragma once")
    w("#include <cstddef>")
    w("#include <cstdint>")
    w("")
    w("namespace ikchain::gdx::gen {")
    w("")
    w("inline constexpr int kEngineVersionMajor = %d;" % header["version_major"])
    w("inline constexpr int kEngineVersionMinor = %d;" % header["version_minor"])
    w("inline constexpr bool kRealIsDouble = %s;" % ("true" if precision == "double" else "false"))
    w("")
    w("struct MethodId { const char* class_name; const char* method; int64_t hash; };")
    w("struct BuiltinMethodId { const char* type; const char* method; int64_t hash; };")
    w("")
    w("// Engine methods called by ptrcall; resolved once at SCENE init (see binding/engine.cpp).")
    w("enum class Method : int {")
    for cls, name, _ in methods:
        w("  %s_%s," % (cls, ident(name)))
    w("  Count")
    w("};")
    w("inline constexpr MethodId kMethods[] = {")
    for cls, name, h in methods:
        w('  {"%s", "%s", %dLL},' % (cls, name, h))
    w("};")
    w("")
    w("enum class BuiltinMethod : int {")
    for t, name, _ in bmethods:
        w("  %s_%s," % (t, ident(name)))
    w("  Count")
    w("};")
    w("inline constexpr BuiltinMethodId kBuiltinMethods[] = {")
    for t, name, h in bmethods:
        w('  {"%s", "%s", %dLL},' % (t, name, h))
    w("};")
    w("")
    w("// Virtual methods we override, by the class that declares them.")
    for cls, name, h in virtuals:
        w("inline constexpr uint32_t kVirtualHash_%s_%s = %du;" % (cls, ident(name), h))
    w("")
    w("// Builtin constructor indices (variant_get_ptr_constructor).")
    for t, args, idx in ctors:
        suffix = "_".join(args) if args else "default"
        w("inline constexpr int32_t kCtor_%s_%s = %d;" % (t, suffix, idx))
    w("")
    for name, values in enum_lines:
        w("namespace %s {" % ident(name))
        for vn, vv in values:
            w("inline constexpr int64_t %s = %d;" % (vn, vv))
        w("}  // namespace %s" % ident(name))
    w("")
    w("// Engine class constants.")
    for cls, name, value in const_lines:
        w("inline constexpr int64_t k%s_%s = %d;" % (cls, name, value))
    w("")
    w("// Builtin sizes for %s." % config)
    for t, s in size_lines:
        w("inline constexpr std::size_t kSize_%s = %d;" % (t, s))
    w("")
    w("}  // namespace ikchain::gdx::gen")
    w("")
    w("// Expanded by binding/builtins.hpp once every ikchain::gdx builtin type is declared: our")
    w("// layouts must match the engine's build configuration byte for byte (ptrcall passes raw memory).")
    w("#define IKCHAIN_GDX_STATIC_ASSERT_BUILTIN_SIZES() \\")
    for t, s in size_lines:
        w('  static_assert(sizeof(::ikchain::gdx::%s) == %d, "gdx::%s must be %d bytes (%s)"); \\'
          % (t, s, t, s, config))
    w("  static_assert(true, \"\")")
    with open(out_path, "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main(sys.argv)
