#include "binding/builtins.hpp"

#include <cstdio>
#include <cstring>
#include <vector>

#include "binding/interface.hpp"

namespace ikchain::gdx {
namespace {

struct Ops {
  GDExtensionPtrConstructor ctor_default = nullptr;
  GDExtensionPtrConstructor ctor_copy = nullptr;
  GDExtensionPtrDestructor dtor = nullptr;
  GDExtensionVariantFromTypeConstructorFunc to_variant = nullptr;
};

struct Table {
  Ops string, string_name, node_path, dictionary, packed_string_array, callable, array, packed_int32_array;
  GDExtensionVariantFromTypeConstructorFunc variant_from_vector3 = nullptr;
  GDExtensionVariantFromTypeConstructorFunc variant_from_transform3d = nullptr;
  GDExtensionTypeFromVariantConstructorFunc array_from_variant = nullptr;
  GDExtensionTypeFromVariantConstructorFunc vector3_from_variant = nullptr;
  GDExtensionTypeFromVariantConstructorFunc transform3d_from_variant = nullptr;
  GDExtensionTypeFromVariantConstructorFunc object_from_variant = nullptr;
  GDExtensionPtrConstructor string_from_string_name = nullptr;
  GDExtensionPtrConstructor string_name_from_string = nullptr;
  GDExtensionPtrConstructor string_from_node_path = nullptr;
  GDExtensionPtrConstructor node_path_from_string = nullptr;
  GDExtensionPtrConstructor callable_from_object_method = nullptr;
  GDExtensionVariantFromTypeConstructorFunc variant_from_bool = nullptr;
  GDExtensionVariantFromTypeConstructorFunc variant_from_int = nullptr;
  GDExtensionVariantFromTypeConstructorFunc variant_from_float = nullptr;
  GDExtensionTypeFromVariantConstructorFunc bool_from_variant = nullptr;
  GDExtensionTypeFromVariantConstructorFunc int_from_variant = nullptr;
  GDExtensionTypeFromVariantConstructorFunc float_from_variant = nullptr;
  GDExtensionTypeFromVariantConstructorFunc string_from_variant = nullptr;
  GDExtensionTypeFromVariantConstructorFunc string_name_from_variant = nullptr;
  GDExtensionTypeFromVariantConstructorFunc node_path_from_variant = nullptr;
  GDExtensionTypeFromVariantConstructorFunc dictionary_from_variant = nullptr;
  GDExtensionPtrBuiltInMethod builtin[int(gen::BuiltinMethod::Count)] = {};
};

// Plain function pointers, filled at initialization; no engine objects live here.
Table t;

Ops ops_for(GDExtensionVariantType type, int32_t default_index, int32_t copy_index) {
  Ops o;
  o.ctor_default = gde.variant_get_ptr_constructor(type, default_index);
  o.ctor_copy = gde.variant_get_ptr_constructor(type, copy_index);
  o.dtor = gde.variant_get_ptr_destructor(type);
  o.to_variant = gde.get_variant_from_type_constructor(type);
  return o;
}

GDExtensionVariantType builtin_type_by_name(const char* name) {
  struct Entry { const char* name; GDExtensionVariantType type; };
  static constexpr Entry kTypes[] = {
      {"String", GDEXTENSION_VARIANT_TYPE_STRING},
      {"NodePath", GDEXTENSION_VARIANT_TYPE_NODE_PATH},
      {"PackedStringArray", GDEXTENSION_VARIANT_TYPE_PACKED_STRING_ARRAY},
      {"Dictionary", GDEXTENSION_VARIANT_TYPE_DICTIONARY},
      {"Array", GDEXTENSION_VARIANT_TYPE_ARRAY},
      {"PackedInt32Array", GDEXTENSION_VARIANT_TYPE_PACKED_INT32_ARRAY},
  };
  for (const Entry& e : kTypes)
    if (std::strcmp(e.name, name) == 0) return e.type;
  return GDEXTENSION_VARIANT_TYPE_NIL;
}

void copy_construct(const Ops& o, void* dst, const void* src) {
  GDExtensionConstTypePtr args[1] = {src};
  o.ctor_copy(dst, args);
}

}  // namespace

bool init_builtins() {
  t.string = ops_for(GDEXTENSION_VARIANT_TYPE_STRING, gen::kCtor_String_default, gen::kCtor_String_String);
  t.string_name = ops_for(GDEXTENSION_VARIANT_TYPE_STRING_NAME, 0, gen::kCtor_StringName_StringName);
  t.node_path = ops_for(GDEXTENSION_VARIANT_TYPE_NODE_PATH, gen::kCtor_NodePath_default, gen::kCtor_NodePath_NodePath);
  t.dictionary = ops_for(GDEXTENSION_VARIANT_TYPE_DICTIONARY, gen::kCtor_Dictionary_default,
                         gen::kCtor_Dictionary_Dictionary);
  t.packed_string_array = ops_for(GDEXTENSION_VARIANT_TYPE_PACKED_STRING_ARRAY, gen::kCtor_PackedStringArray_default,
                                  gen::kCtor_PackedStringArray_PackedStringArray);
  t.callable = ops_for(GDEXTENSION_VARIANT_TYPE_CALLABLE, gen::kCtor_Callable_default, gen::kCtor_Callable_Callable);
  t.array = ops_for(GDEXTENSION_VARIANT_TYPE_ARRAY, gen::kCtor_Array_default, gen::kCtor_Array_Array);
  t.packed_int32_array = ops_for(GDEXTENSION_VARIANT_TYPE_PACKED_INT32_ARRAY, gen::kCtor_PackedInt32Array_default,
                                 gen::kCtor_PackedInt32Array_PackedInt32Array);
  t.variant_from_vector3 = gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_VECTOR3);
  t.variant_from_transform3d = gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_TRANSFORM3D);
  t.array_from_variant = gde.get_variant_to_type_constructor(GDEXTENSION_VARIANT_TYPE_ARRAY);
  t.vector3_from_variant = gde.get_variant_to_type_constructor(GDEXTENSION_VARIANT_TYPE_VECTOR3);
  t.transform3d_from_variant = gde.get_variant_to_type_constructor(GDEXTENSION_VARIANT_TYPE_TRANSFORM3D);
  t.object_from_variant = gde.get_variant_to_type_constructor(GDEXTENSION_VARIANT_TYPE_OBJECT);
  t.string_from_string_name =
      gde.variant_get_ptr_constructor(GDEXTENSION_VARIANT_TYPE_STRING, gen::kCtor_String_StringName);
  t.string_name_from_string =
      gde.variant_get_ptr_constructor(GDEXTENSION_VARIANT_TYPE_STRING_NAME, gen::kCtor_StringName_String);
  t.node_path_from_string =
      gde.variant_get_ptr_constructor(GDEXTENSION_VARIANT_TYPE_NODE_PATH, gen::kCtor_NodePath_String);
  t.string_from_node_path =
      gde.variant_get_ptr_constructor(GDEXTENSION_VARIANT_TYPE_STRING, gen::kCtor_String_NodePath);
  t.callable_from_object_method =
      gde.variant_get_ptr_constructor(GDEXTENSION_VARIANT_TYPE_CALLABLE, gen::kCtor_Callable_Object_StringName);
  t.variant_from_bool = gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_BOOL);
  t.variant_from_int = gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_INT);
  t.variant_from_float = gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_FLOAT);
  t.bool_from_variant = gde.get_variant_to_type_constructor(GDEXTENSION_VARIANT_TYPE_BOOL);
  t.int_from_variant = gde.get_variant_to_type_constructor(GDEXTENSION_VARIANT_TYPE_INT);
  t.float_from_variant = gde.get_variant_to_type_constructor(GDEXTENSION_VARIANT_TYPE_FLOAT);
  t.string_from_variant = gde.get_variant_to_type_constructor(GDEXTENSION_VARIANT_TYPE_STRING);
  t.string_name_from_variant = gde.get_variant_to_type_constructor(GDEXTENSION_VARIANT_TYPE_STRING_NAME);
  t.node_path_from_variant = gde.get_variant_to_type_constructor(GDEXTENSION_VARIANT_TYPE_NODE_PATH);
  t.dictionary_from_variant = gde.get_variant_to_type_constructor(GDEXTENSION_VARIANT_TYPE_DICTIONARY);

  bool ok = true;
  for (int i = 0; i < int(gen::BuiltinMethod::Count); ++i) {
    const gen::BuiltinMethodId& id = gen::kBuiltinMethods[i];
    StringName name(id.method);
    t.builtin[i] = gde.variant_get_ptr_builtin_method(builtin_type_by_name(id.type), name.ptr(), id.hash);
    if (t.builtin[i] == nullptr) {
      std::fprintf(stderr, "IKChain: builtin method %s.%s (hash %lld) not found in this engine\n", id.type,
                   id.method, static_cast<long long>(id.hash));
      ok = false;
    }
  }
  return ok && t.string.dtor && t.string_name.dtor && t.node_path_from_string && t.callable_from_object_method;
}

// ---- StringName ----
StringName::StringName() {}  // all-zero storage is the empty StringName (a null data pointer)
StringName::StringName(std::string_view utf8) {
  gde.string_name_new_with_utf8_chars_and_len(opaque_, utf8.data(), GDExtensionInt(utf8.size()));
}
StringName::StringName(const String& s) {
  GDExtensionConstTypePtr args[1] = {s.ptr()};
  t.string_name_from_string(opaque_, args);
}
StringName::StringName(const StringName& other) { copy_construct(t.string_name, opaque_, other.opaque_); }
StringName& StringName::operator=(const StringName& other) {
  if (this != &other) {
    t.string_name.dtor(opaque_);
    copy_construct(t.string_name, opaque_, other.opaque_);
  }
  return *this;
}
StringName::~StringName() { t.string_name.dtor(opaque_); }
bool StringName::operator==(const StringName& other) const { return equals(other.opaque_); }
bool StringName::equals(GDExtensionConstStringNamePtr other) const {
  return std::memcmp(opaque_, other, sizeof(opaque_)) == 0;
}

// ---- String ----
String::String() {}  // all-zero storage is the empty String (a null CowData pointer)
String::String(std::string_view utf8) {
  gde.string_new_with_utf8_chars_and_len2(opaque_, utf8.data(), GDExtensionInt(utf8.size()));
}
String::String(const StringName& name) {
  GDExtensionConstTypePtr args[1] = {name.ptr()};
  t.string_from_string_name(opaque_, args);
}
String::String(const String& other) { copy_construct(t.string, opaque_, other.opaque_); }
String& String::operator=(const String& other) {
  if (this != &other) {
    t.string.dtor(opaque_);
    copy_construct(t.string, opaque_, other.opaque_);
  }
  return *this;
}
String::~String() { t.string.dtor(opaque_); }
std::string String::utf8() const {
  const GDExtensionInt n = gde.string_to_utf8_chars(opaque_, nullptr, 0);
  std::string out(size_t(n), '\0');
  if (n > 0) gde.string_to_utf8_chars(opaque_, out.data(), n);
  return out;
}
bool String::empty() const { return gde.string_to_utf8_chars(opaque_, nullptr, 0) == 0; }
void String::assign_to(GDExtensionStringPtr engine_string, const String& value) {
  t.string.dtor(engine_string);
  copy_construct(t.string, engine_string, value.opaque_);
}

// ---- NodePath ----
NodePath::NodePath() { t.node_path.ctor_default(opaque_, nullptr); }
NodePath::NodePath(const String& path) {
  GDExtensionConstTypePtr args[1] = {path.ptr()};
  t.node_path_from_string(opaque_, args);
}
NodePath::NodePath(const NodePath& other) { copy_construct(t.node_path, opaque_, other.opaque_); }
NodePath& NodePath::operator=(const NodePath& other) {
  if (this != &other) {
    t.node_path.dtor(opaque_);
    copy_construct(t.node_path, opaque_, other.opaque_);
  }
  return *this;
}
NodePath::~NodePath() { t.node_path.dtor(opaque_); }
bool NodePath::is_empty() const {
  uint8_t result = 1;
  t.builtin[int(gen::BuiltinMethod::NodePath_is_empty)](const_cast<uint8_t*>(opaque_), nullptr, &result, 0);
  return result != 0;
}
String NodePath::to_string() const {
  String s;
  GDExtensionConstTypePtr args[1] = {opaque_};
  t.string.dtor(s.ptr());
  t.string_from_node_path(s.ptr(), args);
  return s;
}

// ---- Dictionary ----
Dictionary::Dictionary() { t.dictionary.ctor_default(opaque_, nullptr); }
Dictionary::Dictionary(const Dictionary& other) { copy_construct(t.dictionary, opaque_, other.opaque_); }
Dictionary& Dictionary::operator=(const Dictionary& other) {
  if (this != &other) {
    t.dictionary.dtor(opaque_);
    copy_construct(t.dictionary, opaque_, other.opaque_);
  }
  return *this;
}
Dictionary::~Dictionary() { t.dictionary.dtor(opaque_); }
void Dictionary::set(const Variant& key, const Variant& value) {
  GDExtensionVariantPtr slot = gde.dictionary_operator_index(opaque_, key.ptr());
  if (slot != nullptr) Variant::assign_to(slot, value);
}

// ---- PackedStringArray ----
PackedStringArray::PackedStringArray() { t.packed_string_array.ctor_default(opaque_, nullptr); }
PackedStringArray::PackedStringArray(const PackedStringArray& other) {
  copy_construct(t.packed_string_array, opaque_, other.opaque_);
}
PackedStringArray& PackedStringArray::operator=(const PackedStringArray& other) {
  if (this != &other) {
    t.packed_string_array.dtor(opaque_);
    copy_construct(t.packed_string_array, opaque_, other.opaque_);
  }
  return *this;
}
PackedStringArray::~PackedStringArray() { t.packed_string_array.dtor(opaque_); }
void PackedStringArray::push_back(const String& s) {
  GDExtensionConstTypePtr args[1] = {s.ptr()};
  uint8_t ignored = 0;
  t.builtin[int(gen::BuiltinMethod::PackedStringArray_push_back)](opaque_, args, &ignored, 1);
}
int64_t PackedStringArray::size() const {
  int64_t n = 0;
  t.builtin[int(gen::BuiltinMethod::PackedStringArray_size)](const_cast<uint8_t*>(opaque_), nullptr, &n, 0);
  return n;
}
String PackedStringArray::get(int64_t i) const {
  String out;
  GDExtensionStringPtr s = gde.packed_string_array_operator_index(const_cast<uint8_t*>(opaque_), i);
  if (s != nullptr) String::assign_to(out.ptr(), *static_cast<const String*>(s));
  return out;
}

// ---- Array ----
Array::Array() { t.array.ctor_default(opaque_, nullptr); }
Array::Array(const Array& other) { copy_construct(t.array, opaque_, other.opaque_); }
Array& Array::operator=(const Array& other) {
  if (this != &other) {
    t.array.dtor(opaque_);
    copy_construct(t.array, opaque_, other.opaque_);
  }
  return *this;
}
Array::~Array() { t.array.dtor(opaque_); }
void Array::push_back(const Variant& value) {
  GDExtensionConstTypePtr args[1] = {value.ptr()};
  t.builtin[int(gen::BuiltinMethod::Array_push_back)](opaque_, args, nullptr, 1);
}
int64_t Array::size() const {
  int64_t n = 0;
  t.builtin[int(gen::BuiltinMethod::Array_size)](const_cast<uint8_t*>(opaque_), nullptr, &n, 0);
  return n;
}
GDExtensionConstVariantPtr Array::at(int64_t i) const {
  if (i < 0 || i >= size()) return nullptr;
  return gde.array_operator_index_const(opaque_, i);
}

// ---- PackedInt32Array ----
PackedInt32Array::PackedInt32Array() { t.packed_int32_array.ctor_default(opaque_, nullptr); }
PackedInt32Array::PackedInt32Array(const PackedInt32Array& other) {
  copy_construct(t.packed_int32_array, opaque_, other.opaque_);
}
PackedInt32Array& PackedInt32Array::operator=(const PackedInt32Array& other) {
  if (this != &other) {
    t.packed_int32_array.dtor(opaque_);
    copy_construct(t.packed_int32_array, opaque_, other.opaque_);
  }
  return *this;
}
PackedInt32Array::~PackedInt32Array() { t.packed_int32_array.dtor(opaque_); }
void PackedInt32Array::push_back(int64_t v) {
  GDExtensionConstTypePtr args[1] = {&v};
  uint8_t ignored = 0;
  t.builtin[int(gen::BuiltinMethod::PackedInt32Array_push_back)](opaque_, args, &ignored, 1);
}
int64_t PackedInt32Array::size() const {
  int64_t n = 0;
  t.builtin[int(gen::BuiltinMethod::PackedInt32Array_size)](const_cast<uint8_t*>(opaque_), nullptr, &n, 0);
  return n;
}
int32_t PackedInt32Array::get(int64_t i) const {
  if (i < 0 || i >= size()) return 0;
  return *gde.packed_int32_array_operator_index_const(opaque_, i);
}

// ---- Callable ----
Callable::Callable(ObjectPtr object, const StringName& method) {
  GDExtensionConstTypePtr args[2] = {&object, method.ptr()};
  t.callable_from_object_method(opaque_, args);
}
Callable::~Callable() { t.callable.dtor(opaque_); }

// ---- Variant ----
Variant::Variant() { gde.variant_new_nil(opaque_); }
Variant::Variant(const Variant& other) { gde.variant_new_copy(opaque_, other.opaque_); }
Variant Variant::copy_of(GDExtensionConstVariantPtr engine_variant) {
  Variant v;
  if (engine_variant == nullptr) return v;
  gde.variant_destroy(v.opaque_);
  gde.variant_new_copy(v.opaque_, engine_variant);
  return v;
}
Variant Variant::from_object(ObjectPtr object) {
  Variant v;
  if (object == nullptr) return v;
  gde.variant_destroy(v.opaque_);
  static GDExtensionVariantFromTypeConstructorFunc from_object = nullptr;
  if (from_object == nullptr) from_object = gde.get_variant_from_type_constructor(GDEXTENSION_VARIANT_TYPE_OBJECT);
  from_object(v.opaque_, &object);
  return v;
}
Variant& Variant::operator=(const Variant& other) {
  if (this != &other) {
    gde.variant_destroy(opaque_);
    gde.variant_new_copy(opaque_, other.opaque_);
  }
  return *this;
}
Variant::~Variant() { gde.variant_destroy(opaque_); }
Variant::Variant(bool v) {
  GDExtensionBool b = v ? 1 : 0;
  t.variant_from_bool(opaque_, &b);
}
Variant::Variant(int64_t v) { t.variant_from_int(opaque_, &v); }
Variant::Variant(double v) { t.variant_from_float(opaque_, &v); }
Variant::Variant(const String& v) { t.string.to_variant(opaque_, const_cast<GDExtensionStringPtr>(v.ptr())); }
Variant::Variant(const NodePath& v) { t.node_path.to_variant(opaque_, const_cast<GDExtensionTypePtr>(v.ptr())); }
Variant::Variant(const Dictionary& v) { t.dictionary.to_variant(opaque_, const_cast<GDExtensionTypePtr>(v.ptr())); }
Variant::Variant(const PackedStringArray& v) {
  t.packed_string_array.to_variant(opaque_, const_cast<GDExtensionTypePtr>(v.ptr()));
}
Variant::Variant(const PackedInt32Array& v) {
  t.packed_int32_array.to_variant(opaque_, const_cast<GDExtensionTypePtr>(v.ptr()));
}
Variant::Variant(const Array& v) { t.array.to_variant(opaque_, const_cast<GDExtensionTypePtr>(v.ptr())); }
Variant::Variant(const Vector3& v) { t.variant_from_vector3(opaque_, const_cast<Vector3*>(&v)); }
Variant::Variant(const Transform3D& v) { t.variant_from_transform3d(opaque_, const_cast<Transform3D*>(&v)); }
GDExtensionVariantType Variant::type() const { return gde.variant_get_type(opaque_); }
void Variant::assign_to(GDExtensionVariantPtr engine_variant, const Variant& value) {
  gde.variant_destroy(engine_variant);
  gde.variant_new_copy(engine_variant, value.opaque_);
}

// ---- Variant -> value ----
// The engine's to-type constructors read the Variant's payload as that type without converting,
// so the type is always checked first. They construct into the destination as uninitialized
// memory (GDExtensionUninitializedTypePtr: a placement new, not an assignment), so a destination
// that holds a value is destroyed first: constructing over it would leak what it owned (a
// default Array or Dictionary owns a heap block; a String, NodePath or packed array its data).
namespace {
void construct_from_variant(GDExtensionTypeFromVariantConstructorFunc to_type, GDExtensionPtrDestructor dtor,
                            GDExtensionTypePtr dst, GDExtensionConstVariantPtr v) {
  dtor(dst);
  to_type(dst, const_cast<GDExtensionVariantPtr>(v));
}
}  // namespace
ScalarVariant decode_scalar(GDExtensionConstVariantPtr v) {
  ScalarVariant s;
  s.type = uint32_t(gde.variant_get_type(v));
  auto* mv = const_cast<GDExtensionVariantPtr>(v);
  switch (VariantType(s.type)) {
    case VariantType::Bool: {
      GDExtensionBool b = 0;
      t.bool_from_variant(&b, mv);
      s.b = b != 0;
      break;
    }
    case VariantType::Int: t.int_from_variant(&s.i, mv); break;
    case VariantType::Float: t.float_from_variant(&s.f, mv); break;
    default: break;
  }
  return s;
}
bool variant_to(GDExtensionConstVariantPtr v, bool& out) { return scalar_to_bool(decode_scalar(v), out); }
bool variant_to(GDExtensionConstVariantPtr v, int64_t& out) { return scalar_to_int64(decode_scalar(v), out); }
bool variant_to(GDExtensionConstVariantPtr v, double& out) { return scalar_to_double(decode_scalar(v), out); }
bool variant_to(GDExtensionConstVariantPtr v, String& out) {
  switch (gde.variant_get_type(v)) {
    case GDEXTENSION_VARIANT_TYPE_STRING:
      construct_from_variant(t.string_from_variant, t.string.dtor, out.ptr(), v);
      return true;
    case GDEXTENSION_VARIANT_TYPE_STRING_NAME: {
      StringName name;
      construct_from_variant(t.string_name_from_variant, t.string_name.dtor, name.ptr(), v);
      out = String(name);
      return true;
    }
    case GDEXTENSION_VARIANT_TYPE_NODE_PATH: {
      NodePath path;
      construct_from_variant(t.node_path_from_variant, t.node_path.dtor, path.ptr(), v);
      out = path.to_string();
      return true;
    }
    default: return false;
  }
}
bool variant_to(GDExtensionConstVariantPtr v, NodePath& out) {
  switch (gde.variant_get_type(v)) {
    case GDEXTENSION_VARIANT_TYPE_NODE_PATH:
      construct_from_variant(t.node_path_from_variant, t.node_path.dtor, out.ptr(), v);
      return true;
    case GDEXTENSION_VARIANT_TYPE_STRING:
    case GDEXTENSION_VARIANT_TYPE_STRING_NAME: {
      String s;
      if (!variant_to(v, s)) return false;
      out = NodePath(s);
      return true;
    }
    default: return false;
  }
}
bool variant_to(GDExtensionConstVariantPtr v, Dictionary& out) {
  if (gde.variant_get_type(v) != GDEXTENSION_VARIANT_TYPE_DICTIONARY) return false;
  construct_from_variant(t.dictionary_from_variant, t.dictionary.dtor, out.ptr(), v);
  return true;
}

bool variant_to(GDExtensionConstVariantPtr v, Array& out) {
  if (gde.variant_get_type(v) != GDEXTENSION_VARIANT_TYPE_ARRAY) return false;
  construct_from_variant(t.array_from_variant, t.array.dtor, out.ptr(), v);
  return true;
}
bool variant_to(GDExtensionConstVariantPtr v, Vector3& out) {
  if (gde.variant_get_type(v) != GDEXTENSION_VARIANT_TYPE_VECTOR3) return false;
  t.vector3_from_variant(&out, const_cast<GDExtensionVariantPtr>(v));
  return true;
}
bool variant_to(GDExtensionConstVariantPtr v, Transform3D& out) {
  if (gde.variant_get_type(v) != GDEXTENSION_VARIANT_TYPE_TRANSFORM3D) return false;
  t.transform3d_from_variant(&out, const_cast<GDExtensionVariantPtr>(v));
  return true;
}
bool variant_to(GDExtensionConstVariantPtr v, ObjectPtr& out) {
  out = nullptr;
  switch (gde.variant_get_type(v)) {
    case GDEXTENSION_VARIANT_TYPE_NIL: return true;
    case GDEXTENSION_VARIANT_TYPE_OBJECT: t.object_from_variant(&out, const_cast<GDExtensionVariantPtr>(v)); return true;
    default: return false;
  }
}

}  // namespace ikchain::gdx
