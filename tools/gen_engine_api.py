#!/usr/bin/env python3
"""Generates engine_api.gen.hpp and engine_classes.gen.hpp from Godot's dumped extension_api.json.

Reads a list of the engine entities the extension uses (src/godot/engine_api.txt) and emits, for
each, the identifiers Godot needs to resolve it at run time: method hashes, virtual hashes, builtin
constructor indices, enum values and builtin sizes. Hashes never get typed by hand: if the engine
we build against lacks an entry (or changed its signature), the build stops here naming it.

engine_classes.gen.hpp holds one typed wrapper per engine class a listed method belongs to (and
their ancestors), with one member function per listed method whose parameter and return types come
from extension_api.json (like godot-cpp's binding_generator.py): `skeleton.get_bone_rest(i)` returns
a Transform3D, so a wrong type at the call site is a compile error.

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
    if len(argv) != 5:
        fail("usage: gen_engine_api.py extension_api.json engine_api.txt engine_api.gen.hpp engine_classes.gen.hpp")
    api_path, list_path, out_path, classes_out_path = argv[1:]
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
    method_defs = []  # (declaring class, method json, where) for the typed wrappers

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
                if kind == "method":
                    method_defs.append((owner, m, where))
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
    write_classes(classes_out_path, header, classes, method_defs)


# Builtin types our binding implements (binding/builtins.hpp, binding/math.hpp), passed by const&.
BUILTIN_TYPES = {"String", "StringName", "NodePath", "Vector3", "Quaternion", "Basis", "Transform3D",
                 "Dictionary", "Array", "PackedStringArray", "PackedInt32Array", "Callable", "Variant"}


def cpp_type(t, classes, wrapped, where):
    """(C++ type, kind) with kind in scalar / builtin / object."""
    if t == "int" or t.startswith("enum::") or t.startswith("bitfield::"):
        return "int64_t", "scalar"
    if t == "float":
        return "double", "scalar"
    if t == "bool":
        return "bool", "scalar"
    if t.startswith("typedarray::"):
        return "Array", "builtin"
    if t in BUILTIN_TYPES:
        return t, "builtin"
    if t in classes:
        return (t if t in wrapped else "Object"), "object"
    fail("%s: type %s is not supported by the binding (add it to binding/builtins.hpp)" % (where, t))


def write_classes(path, header, classes, method_defs):
    # Every declaring class and its ancestors get a wrapper, so inheritance mirrors the engine's.
    wrapped = set()
    for owner, _, _ in method_defs:
        c = owner
        while c is not None and c not in wrapped:
            wrapped.add(c)
            c = classes[c].get("inherits")
    wrapped.add("Object")

    def depth(c):
        d = 0
        while classes[c].get("inherits"):
            c = classes[c]["inherits"]
            d += 1
        return d

    order = sorted(wrapped, key=lambda c: (depth(c), c))
    by_class = {c: [] for c in order}
    for owner, m, where in method_defs:
        by_class[owner].append((m, where))

    out = []
    w = out.append
    w("// Generated by tools/gen_engine_api.py from %s. Do not edit." % header["version_full_name"])
    w("// Typed wrappers of the engine classes IKChain calls (see src/godot/engine_api.txt).")
    w("#pragma once")
    w("#include <cstdint>")
    w("")
    w('#include "binding/engine.hpp"')
    w("")
    w("namespace ikchain::gdx {")
    w("")
    w("// Class tags for casts, resolved at SCENE init (binding/engine.cpp).")
    w("enum class ClassTag : int {")
    for c in order:
        w("  %s," % c)
    w("  Count")
    w("};")
    w("inline constexpr const char* kClassTagNames[] = {%s};" % ", ".join('"%s"' % c for c in order))
    w("")
    for c in order:
        parent = classes[c].get("inherits")
        if c == "Object":
            w("class Object {")
            w(" public:")
            w("  Object() = default;")
            w("  explicit Object(ObjectPtr p) : ptr_(p) {}")
            w("  ObjectPtr ptr() const { return ptr_; }")
            w("  explicit operator bool() const { return ptr_ != nullptr; }")
            w("  bool operator==(const Object& o) const { return ptr_ == o.ptr_; }")
            w("  bool operator!=(const Object& o) const { return ptr_ != o.ptr_; }")
            w("  uint64_t instance_id() const { return ptr_ ? gde.object_get_instance_id(ptr_) : 0; }")
            w("  static Object cast(ObjectPtr p) { return Object(p); }")
            w("  static Object unchecked(ObjectPtr p) { return Object(p); }")
        else:
            w("class %s : public %s {" % (c, parent))
            w(" public:")
            w("  %s() = default;" % c)
            w("  // Null unless `p` is a %s (or derives from it)." % c)
            w("  static %s cast(ObjectPtr p) {" % c)
            w("    return %s(p ? gde.object_cast_to(p, class_tag(ClassTag::%s)) : nullptr);" % (c, c))
            w("  }")
            w("  static %s cast(const Object& o) { return cast(o.ptr()); }" % c)
            w("  // For pointers the engine declares to be a %s (a typed return value)." % c)
            w("  static %s unchecked(ObjectPtr p) { return %s(p); }" % (c, c))
        for m, where in by_class[c]:
            args = m.get("arguments", [])
            params, call_args = [], []
            for a in args:
                t, kind = cpp_type(a["type"], classes, wrapped, where)
                name = "p_" + a["name"]
                default = ""
                dv = a.get("default_value")
                if kind == "scalar" and dv is not None and dv.lstrip("-").isdigit():
                    default = " = %s" % dv
                if kind == "builtin":
                    params.append("const %s& %s%s" % (t, name, default))
                    call_args.append(name)
                elif kind == "object":
                    params.append("const %s& %s" % (t, name))
                    call_args.append("%s.ptr()" % name)
                else:
                    params.append("%s %s%s" % (t, name, default))
                    call_args.append(name)
            ret = m.get("return_value")
            enum_id = "gen::Method::%s_%s" % (c, ident(m["name"]))
            callee = ", ".join(["%s" % enum_id, "ptr()"] + call_args)
            if ret is None:
                w("  void %s(%s) const { call<void>(%s); }" % (m["name"], ", ".join(params), callee))
            else:
                rt, rkind = cpp_type(ret["type"], classes, wrapped, where)
                if rkind == "object":
                    w("  %s %s(%s) const { return %s::unchecked(call<ObjectPtr>(%s)); }"
                      % (rt, m["name"], ", ".join(params), rt, callee))
                else:
                    w("  %s %s(%s) const { return call<%s>(%s); }"
                      % (rt, m["name"], ", ".join(params), rt, callee))
        if c == "Object":
            w(" protected:")
            w("  ObjectPtr ptr_ = nullptr;")
        else:
            w(" protected:")
            w("  explicit %s(ObjectPtr p) : %s(p) {}" % (c, parent))
        w("};")
        w("")
    w("}  // namespace ikchain::gdx")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main(sys.argv)
