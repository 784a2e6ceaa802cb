// Godot's reference-counted builtins (String, StringName, NodePath, Dictionary,
// PackedStringArray, Callable) and Variant as opaque storage of the engine's size, managed through
// the constructors/destructors the engine hands out (resolved once by init_builtins()).
// Sizes are checked against the dumped extension_api.json at the end of this header.
#pragma once

#include <gdextension_interface.h>

#include <cstdint>
#include <string>
#include <string_view>

#include "binding/math.hpp"
#include "binding/variant_args.hpp"
#include "engine_api.gen.hpp"

namespace ikchain::gdx {

using ObjectPtr = GDExtensionObjectPtr;

// Resolves constructors, destructors and builtin methods; call once gde is loaded.
bool init_builtins();

class String;

class StringName {
 public:
  StringName();
  explicit StringName(std::string_view utf8);
  explicit StringName(const String& s);
  StringName(const StringName& other);
  StringName& operator=(const StringName& other);
  ~StringName();
  // Interned: equal names share one data pointer, so comparing the storage compares the names.
  bool operator==(const StringName& other) const;
  bool equals(GDExtensionConstStringNamePtr other) const;
  GDExtensionStringNamePtr ptr() { return opaque_; }
  GDExtensionConstStringNamePtr ptr() const { return opaque_; }

 private:
  alignas(8) uint8_t opaque_[gen::kSize_StringName] = {};
};

class String {
 public:
  String();
  String(std::string_view utf8);  // NOLINT: implicit from text is the point
  explicit String(const StringName& name);
  String(const String& other);
  String& operator=(const String& other);
  ~String();
  std::string utf8() const;
  bool empty() const;
  GDExtensionStringPtr ptr() { return opaque_; }
  GDExtensionConstStringPtr ptr() const { return opaque_; }
  // For a String the engine owns (a hint_string in validate_property, a ptrcall return slot).
  static void assign_to(GDExtensionStringPtr engine_string, const String& value);

 private:
  alignas(8) uint8_t opaque_[gen::kSize_String] = {};
};

class NodePath {
 public:
  NodePath();
  explicit NodePath(const String& path);
  NodePath(const NodePath& other);
  NodePath& operator=(const NodePath& other);
  ~NodePath();
  bool is_empty() const;
  String to_string() const;
  GDExtensionTypePtr ptr() { return opaque_; }
  GDExtensionConstTypePtr ptr() const { return opaque_; }

 private:
  alignas(8) uint8_t opaque_[gen::kSize_NodePath] = {};
};

class Variant;

class Dictionary {
 public:
  Dictionary();
  Dictionary(const Dictionary& other);
  Dictionary& operator=(const Dictionary& other);
  ~Dictionary();
  void set(const Variant& key, const Variant& value);
  GDExtensionTypePtr ptr() { return opaque_; }
  GDExtensionConstTypePtr ptr() const { return opaque_; }

 private:
  alignas(8) uint8_t opaque_[gen::kSize_Dictionary] = {};
};

class PackedStringArray {
 public:
  PackedStringArray();
  PackedStringArray(const PackedStringArray& other);
  PackedStringArray& operator=(const PackedStringArray& other);
  ~PackedStringArray();
  void push_back(const String& s);
  int64_t size() const;
  String get(int64_t i) const;
  GDExtensionTypePtr ptr() { return opaque_; }
  GDExtensionConstTypePtr ptr() const { return opaque_; }

 private:
  alignas(8) uint8_t opaque_[gen::kSize_PackedStringArray] = {};
};

class Array {
 public:
  Array();
  Array(const Array& other);
  Array& operator=(const Array& other);
  ~Array();
  int64_t size() const;
  void push_back(const Variant& value);
  // The element's Variant (owned by the array); null when out of range.
  GDExtensionConstVariantPtr at(int64_t i) const;
  GDExtensionTypePtr ptr() { return opaque_; }
  GDExtensionConstTypePtr ptr() const { return opaque_; }

 private:
  alignas(8) uint8_t opaque_[gen::kSize_Array] = {};
};

class PackedInt32Array {
 public:
  PackedInt32Array();
  PackedInt32Array(const PackedInt32Array& other);
  PackedInt32Array& operator=(const PackedInt32Array& other);
  ~PackedInt32Array();
  void push_back(int64_t v);
  int64_t size() const;
  int32_t get(int64_t i) const;
  GDExtensionTypePtr ptr() { return opaque_; }
  GDExtensionConstTypePtr ptr() const { return opaque_; }

 private:
  alignas(8) uint8_t opaque_[gen::kSize_PackedInt32Array] = {};
};

class Callable {
 public:
  Callable(ObjectPtr object, const StringName& method);
  Callable(const Callable&) = delete;
  Callable& operator=(const Callable&) = delete;
  ~Callable();
  GDExtensionTypePtr ptr() { return opaque_; }
  GDExtensionConstTypePtr ptr() const { return opaque_; }

 private:
  alignas(8) uint8_t opaque_[gen::kSize_Callable] = {};
};

class Variant {
 public:
  Variant();  // nil
  Variant(const Variant& other);
  Variant& operator=(const Variant& other);
  ~Variant();
  explicit Variant(bool v);
  explicit Variant(int64_t v);
  explicit Variant(double v);
  explicit Variant(const String& v);
  explicit Variant(const char* utf8) : Variant(String(utf8)) {}
  explicit Variant(const NodePath& v);
  explicit Variant(const Dictionary& v);
  explicit Variant(const PackedStringArray& v);
  explicit Variant(const PackedInt32Array& v);
  explicit Variant(const Array& v);
  explicit Variant(const Vector3& v);
  explicit Variant(const Transform3D& v);

  // A copy of an engine-owned Variant (an Array element): holds a reference to its object.
  static Variant copy_of(GDExtensionConstVariantPtr engine_variant);
  // An Object as a Variant (a RefCounted object gets its first or next reference).
  static Variant from_object(ObjectPtr object);

  GDExtensionVariantType type() const;
  GDExtensionVariantPtr ptr() { return opaque_; }
  GDExtensionConstVariantPtr ptr() const { return opaque_; }

  // Writes `value` into a Variant the engine owns (call_func's r_return, a property getter).
  static void assign_to(GDExtensionVariantPtr engine_variant, const Variant& value);

 private:
  alignas(8) uint8_t opaque_[gen::kSize_Variant] = {};
};

}  // namespace ikchain::gdx

IKCHAIN_GDX_STATIC_ASSERT_BUILTIN_SIZES();

namespace ikchain::gdx {

// Variant -> C++ value for the Variant-call path. Each accepts what Godot's strict conversion
// accepts (int/float/bool among themselves; String/StringName/NodePath among themselves) and
// returns false otherwise. Numbers convert by value (see variant_args.hpp), never by bits.
ScalarVariant decode_scalar(GDExtensionConstVariantPtr v);
bool variant_to(GDExtensionConstVariantPtr v, bool& out);
bool variant_to(GDExtensionConstVariantPtr v, int64_t& out);
bool variant_to(GDExtensionConstVariantPtr v, double& out);
bool variant_to(GDExtensionConstVariantPtr v, String& out);
bool variant_to(GDExtensionConstVariantPtr v, NodePath& out);
bool variant_to(GDExtensionConstVariantPtr v, Dictionary& out);
bool variant_to(GDExtensionConstVariantPtr v, Array& out);
bool variant_to(GDExtensionConstVariantPtr v, Vector3& out);
bool variant_to(GDExtensionConstVariantPtr v, Transform3D& out);
// An Object (null for a nil Variant or a freed object); false for any other type.
bool variant_to(GDExtensionConstVariantPtr v, ObjectPtr& out);

}  // namespace ikchain::gdx
