// Registration of an extension class with ClassDB: construction/destruction, methods with named
// arguments (both the ptrcall and the Variant-call path), properties with hints and usage, integer
// constants in named enums, and virtual overrides dispatched by name + hash
// (get_virtual_call_data2 / call_virtual_with_data).
//
// Everything registered here (StringNames included) is created at SCENE init and released by
// ClassDb::release() at SCENE deinit: no engine object lives in a static.
#pragma once

#include <gdextension_interface.h>

#include <initializer_list>
#include <memory>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "binding/builtins.hpp"
#include "binding/classes.hpp"
#include "binding/interface.hpp"
#include "binding/log.hpp"

namespace ikchain::gdx {

// ---- argument traits for our bound methods ----
template <class T>
struct ArgTraits;

template <>
struct ArgTraits<bool> {
  static constexpr GDExtensionVariantType kType = GDEXTENSION_VARIANT_TYPE_BOOL;
  static constexpr GDExtensionClassMethodArgumentMetadata kMeta = GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE;
  static bool from_ptr(GDExtensionConstTypePtr p) { return *static_cast<const uint8_t*>(p) != 0; }
  static void to_ptr(bool v, GDExtensionTypePtr r) { *static_cast<uint8_t*>(r) = v ? 1 : 0; }
};
template <>
struct ArgTraits<int64_t> {
  static constexpr GDExtensionVariantType kType = GDEXTENSION_VARIANT_TYPE_INT;
  static constexpr GDExtensionClassMethodArgumentMetadata kMeta = GDEXTENSION_METHOD_ARGUMENT_METADATA_INT_IS_INT64;
  static int64_t from_ptr(GDExtensionConstTypePtr p) { return *static_cast<const int64_t*>(p); }
  static void to_ptr(int64_t v, GDExtensionTypePtr r) { *static_cast<int64_t*>(r) = v; }
};
template <>
struct ArgTraits<double> {
  static constexpr GDExtensionVariantType kType = GDEXTENSION_VARIANT_TYPE_FLOAT;
  static constexpr GDExtensionClassMethodArgumentMetadata kMeta = GDEXTENSION_METHOD_ARGUMENT_METADATA_REAL_IS_DOUBLE;
  static double from_ptr(GDExtensionConstTypePtr p) { return *static_cast<const double*>(p); }
  static void to_ptr(double v, GDExtensionTypePtr r) { *static_cast<double*>(r) = v; }
};
// Builtins: ptrcall hands a pointer to a live value of the engine's layout; return slots hold a
// constructed value that we assign to.
template <class T, GDExtensionVariantType VT>
struct BuiltinArgTraits {
  static constexpr GDExtensionVariantType kType = VT;
  static constexpr GDExtensionClassMethodArgumentMetadata kMeta = GDEXTENSION_METHOD_ARGUMENT_METADATA_NONE;
  static T from_ptr(GDExtensionConstTypePtr p) { return *static_cast<const T*>(p); }
  static void to_ptr(const T& v, GDExtensionTypePtr r) { *static_cast<T*>(r) = v; }
};
template <>
struct ArgTraits<String> : BuiltinArgTraits<String, GDEXTENSION_VARIANT_TYPE_STRING> {};
template <>
struct ArgTraits<NodePath> : BuiltinArgTraits<NodePath, GDEXTENSION_VARIANT_TYPE_NODE_PATH> {};
template <>
struct ArgTraits<Dictionary> : BuiltinArgTraits<Dictionary, GDEXTENSION_VARIANT_TYPE_DICTIONARY> {};
template <>
struct ArgTraits<PackedStringArray> : BuiltinArgTraits<PackedStringArray, GDEXTENSION_VARIANT_TYPE_PACKED_STRING_ARRAY> {};
template <>
struct ArgTraits<PackedInt32Array> : BuiltinArgTraits<PackedInt32Array, GDEXTENSION_VARIANT_TYPE_PACKED_INT32_ARRAY> {};
template <>
struct ArgTraits<Array> : BuiltinArgTraits<Array, GDEXTENSION_VARIANT_TYPE_ARRAY> {};
template <>
struct ArgTraits<Vector3> : BuiltinArgTraits<Vector3, GDEXTENSION_VARIANT_TYPE_VECTOR3> {};
template <>
struct ArgTraits<Transform3D> : BuiltinArgTraits<Transform3D, GDEXTENSION_VARIANT_TYPE_TRANSFORM3D> {};

// What a bound method returns, beyond its C++ type: an enum (`return_class` = "Class.Enum",
// shown as such in the class reference) or a typed array (`return_array_of` = "IKChainJoint").
struct ReturnInfo {
  const char* return_enum = nullptr;
  const char* return_array_of = nullptr;
};

// ---- property description ----
struct PropertySpec {
  const char* name;
  GDExtensionVariantType type;
  int64_t hint = gen::PropertyHint::PROPERTY_HINT_NONE;
  const char* hint_string = "";
  int64_t usage = gen::PropertyUsageFlags::PROPERTY_USAGE_DEFAULT;
  const char* class_name = "";
};

// Owns the names and per-method data handed to the engine, for one class.
struct ClassRecord;

struct MethodRecordBase {
  virtual ~MethodRecordBase() = default;
  std::string class_name, method_name;
  std::vector<std::string> arg_names;
  void report_bad_argument(int32_t index, GDExtensionVariantType expected, GDExtensionVariantType got) const;
};

// A virtual of the engine parent that the class overrides, dispatched by name + hash.
struct VirtualRecord {
  VirtualRecord(const char* n, uint32_t h) : name(n), hash(h) {}
  virtual ~VirtualRecord() = default;
  virtual void call(void* instance, const GDExtensionConstTypePtr* args, GDExtensionTypePtr r_ret) const = 0;
  StringName name;
  uint32_t hash;
};

struct ClassRecord {
  StringName name;
  StringName parent;
  std::vector<std::unique_ptr<MethodRecordBase>> methods;
  std::vector<std::unique_ptr<VirtualRecord>> virtuals;
};

// Instance bindings: every instance of our classes is registered with the engine object that owns
// it, so an Object found in an Array (a Resource of ours) leads back to its C++ instance.
inline const GDExtensionInstanceBindingCallbacks kInstanceBindingCallbacks = {
    /*create_callback=*/[](void*, void*) -> void* { return nullptr; },
    /*free_callback=*/[](void*, void*, void*) {},
    /*reference_callback=*/[](void*, void*, GDExtensionBool) -> GDExtensionBool { return 1; },
};

// The C++ instance of class C (registered under `class_name`) behind `object`; null when `object`
// is null or not a C.
template <class C>
C* instance_of(ObjectPtr object, const String& class_name) {
  if (object == nullptr || !Object(object).is_class(class_name)) return nullptr;
  return static_cast<C*>(gde.object_get_instance_binding(object, gde.library, &kInstanceBindingCallbacks));
}

namespace detail {

template <class T>
using bare_t = std::remove_cv_t<std::remove_reference_t<T>>;

inline void set_call_error(GDExtensionCallError* e, GDExtensionCallErrorType type, int32_t argument, int32_t expected) {
  if (e == nullptr) return;
  e->error = type;
  e->argument = argument;
  e->expected = expected;
}

// One bound member function of C: R (C::*)(A...), const or not. Both call paths decode the
// arguments with ArgTraits / variant_to and invoke the member directly.
template <class C, class R, class... A>
struct MethodRecord final : MethodRecordBase {
  using Fn = R (C::*)(A...);
  using ConstFn = R (C::*)(A...) const;
  Fn fn = nullptr;
  ConstFn const_fn = nullptr;
  explicit MethodRecord(Fn f) : fn(f) {}
  explicit MethodRecord(ConstFn f) : const_fn(f) {}

  template <class... V>
  R invoke(C& obj, V&&... values) const {
    return const_fn ? (obj.*const_fn)(std::forward<V>(values)...) : (obj.*fn)(std::forward<V>(values)...);
  }

  template <size_t... I>
  static void ptrcall_impl(MethodRecord* self, C& obj, const GDExtensionConstTypePtr* args, GDExtensionTypePtr r_ret,
                           std::index_sequence<I...>) {
    if constexpr (std::is_void_v<R>) {
      self->invoke(obj, ArgTraits<bare_t<A>>::from_ptr(args[I])...);
    } else {
      ArgTraits<bare_t<R>>::to_ptr(self->invoke(obj, ArgTraits<bare_t<A>>::from_ptr(args[I])...), r_ret);
    }
  }

  static void ptrcall(void* userdata, GDExtensionClassInstancePtr instance, const GDExtensionConstTypePtr* args,
                      GDExtensionTypePtr r_ret) {
    try {
      auto* self = static_cast<MethodRecord*>(userdata);
      ptrcall_impl(self, *static_cast<C*>(instance), args, r_ret, std::index_sequence_for<A...>{});
    } catch (...) {
      IKCHAIN_PRINT_ERROR("IKChain: unexpected C++ exception in a bound method");
    }
  }

  template <size_t... I>
  static void call_impl(MethodRecord* self, C& obj, const GDExtensionConstVariantPtr* args, GDExtensionVariantPtr r_ret,
                        GDExtensionCallError* r_error, std::index_sequence<I...>) {
    std::tuple<bare_t<A>...> values;
    int32_t bad = -1;
    // Convert every argument by value; the first that cannot be converted is reported.
    ((bad < 0 && !variant_to(args[I], std::get<I>(values)) ? (bad = int32_t(I), 0) : 0), ...);
    if (bad >= 0) {
      constexpr GDExtensionVariantType kExpected[] = {ArgTraits<bare_t<A>>::kType..., GDEXTENSION_VARIANT_TYPE_NIL};
      set_call_error(r_error, GDEXTENSION_CALL_ERROR_INVALID_ARGUMENT, bad, int32_t(kExpected[bad]));
      // Object::set() drops a failed setter call without a word: say which call and argument.
      self->report_bad_argument(bad, kExpected[bad], gde.variant_get_type(args[bad]));
      return;
    }
    if constexpr (std::is_void_v<R>) {
      self->invoke(obj, std::move(std::get<I>(values))...);
    } else {
      Variant::assign_to(r_ret, Variant(self->invoke(obj, std::move(std::get<I>(values))...)));
    }
  }

  static void call(void* userdata, GDExtensionClassInstancePtr instance, const GDExtensionConstVariantPtr* args,
                   GDExtensionInt argc, GDExtensionVariantPtr r_ret, GDExtensionCallError* r_error) {
    try {
      set_call_error(r_error, GDEXTENSION_CALL_OK, 0, 0);
      if (instance == nullptr) {
        set_call_error(r_error, GDEXTENSION_CALL_ERROR_INSTANCE_IS_NULL, 0, 0);
        return;
      }
      if (argc < GDExtensionInt(sizeof...(A))) {
        set_call_error(r_error, GDEXTENSION_CALL_ERROR_TOO_FEW_ARGUMENTS, 0, int32_t(sizeof...(A)));
        return;
      }
      if (argc > GDExtensionInt(sizeof...(A))) {
        set_call_error(r_error, GDEXTENSION_CALL_ERROR_TOO_MANY_ARGUMENTS, 0, int32_t(sizeof...(A)));
        return;
      }
      call_impl(static_cast<MethodRecord*>(userdata), *static_cast<C*>(instance), args, r_ret, r_error,
                std::index_sequence_for<A...>{});
    } catch (...) {
      IKCHAIN_PRINT_ERROR("IKChain: unexpected C++ exception in a bound method");
    }
  }
};

template <class T, class = void>
struct has_validate_property : std::false_type {};
template <class T>
struct has_validate_property<T, std::void_t<decltype(std::declval<T&>().validate_property(
                                    std::declval<GDExtensionPropertyInfo&>()))>> : std::true_type {};
template <class T, class = void>
struct has_notification : std::false_type {};
template <class T>
struct has_notification<T, std::void_t<decltype(std::declval<T&>().notification(int32_t(0)))>> : std::true_type {};

// A virtual override bound to a member function: arguments arrive in ptrcall encoding.
template <class C, bool Const, class R, class... A>
struct VirtualMethod final : VirtualRecord {
  using Fn = std::conditional_t<Const, R (C::*)(A...) const, R (C::*)(A...)>;
  VirtualMethod(const char* n, uint32_t h, Fn f) : VirtualRecord(n, h), fn(f) {}
  Fn fn;

  template <size_t... I>
  void call_impl(C& obj, const GDExtensionConstTypePtr* args, GDExtensionTypePtr r_ret,
                 std::index_sequence<I...>) const {
    if constexpr (std::is_void_v<R>) {
      (obj.*fn)(ArgTraits<bare_t<A>>::from_ptr(args[I])...);
    } else {
      ArgTraits<bare_t<R>>::to_ptr((obj.*fn)(ArgTraits<bare_t<A>>::from_ptr(args[I])...), r_ret);
    }
  }
  void call(void* instance, const GDExtensionConstTypePtr* args, GDExtensionTypePtr r_ret) const override {
    call_impl(*static_cast<C*>(instance), args, r_ret, std::index_sequence_for<A...>{});
  }
};

}  // namespace detail

// Registers class C (constructible as C(ObjectPtr owner)) deriving from an engine class.
template <class C>
class ClassBuilder {
 public:
  ClassBuilder(ClassRecord& record) : record_(record) {}

  // C::validate_property(GDExtensionPropertyInfo&) and C::notification(int32_t what) are
  // installed when C declares them.
  void register_class() {
    GDExtensionClassCreationInfo5 info{};
    info.is_virtual = 0;
    info.is_abstract = 0;
    info.is_exposed = 1;
    info.is_runtime = 0;
    if constexpr (detail::has_validate_property<C>::value) info.validate_property_func = &validate_property;
    if constexpr (detail::has_notification<C>::value) info.notification_func = &notification;
    info.create_instance_func = &create_instance;
    info.free_instance_func = &free_instance;
    info.get_virtual_call_data_func = &get_virtual_call_data;
    info.call_virtual_with_data_func = &call_virtual_with_data;
    info.class_userdata = &record_;
    gde.classdb_register_extension_class5(gde.library, record_.name.ptr(), record_.parent.ptr(), &info);
  }

  // Binds the member function `fn` as `name`, with named arguments (like godot-cpp's
  // ClassDB::bind_method(D_METHOD("set_x", "x"), &C::set_x)); types are deduced from `fn`.
  template <class R, class... A>
  void method(const char* name, R (C::*fn)(A...), std::initializer_list<const char*> arg_names = {},
              ReturnInfo ret = {}) {
    add_method<R, A...>(name, std::make_unique<detail::MethodRecord<C, R, A...>>(fn), arg_names, false, ret);
  }
  template <class R, class... A>
  void method(const char* name, R (C::*fn)(A...) const, std::initializer_list<const char*> arg_names = {},
              ReturnInfo ret = {}) {
    add_method<R, A...>(name, std::make_unique<detail::MethodRecord<C, R, A...>>(fn), arg_names, true, ret);
  }
  // A member C inherits from a base class (what several of our classes share is bound once there).
  template <class B, class R, class... A, std::enable_if_t<std::is_base_of_v<B, C> && !std::is_same_v<B, C>, int> = 0>
  void method(const char* name, R (B::*fn)(A...), std::initializer_list<const char*> arg_names = {},
              ReturnInfo ret = {}) {
    method(name, static_cast<R (C::*)(A...)>(fn), arg_names, ret);
  }
  template <class B, class R, class... A, std::enable_if_t<std::is_base_of_v<B, C> && !std::is_same_v<B, C>, int> = 0>
  void method(const char* name, R (B::*fn)(A...) const, std::initializer_list<const char*> arg_names = {},
              ReturnInfo ret = {}) {
    method(name, static_cast<R (C::*)(A...) const>(fn), arg_names, ret);
  }

 private:
  template <class R, class... A>
  void add_method(const char* name, std::unique_ptr<detail::MethodRecord<C, R, A...>> record,
                  std::initializer_list<const char*> arg_names, bool is_const, ReturnInfo ret) {
    static_assert(sizeof...(A) < 8, "too many arguments");
    StringName method_name(name);
    record->class_name = String(record_.name).utf8();
    record->method_name = name;
    for (const char* n : arg_names) record->arg_names.emplace_back(n);
    std::vector<StringName> names;
    std::vector<String> hints;
    StringName empty_class;
    for (const char* n : arg_names) names.emplace_back(n);
    while (names.size() < sizeof...(A)) names.emplace_back("arg");
    hints.resize(sizeof...(A) + 1);
    GDExtensionPropertyInfo args_info[sizeof...(A) + 1] = {};
    GDExtensionClassMethodArgumentMetadata args_meta[sizeof...(A) + 1] = {};
    size_t i = 0;
    ((args_info[i] = GDExtensionPropertyInfo{ArgTraits<detail::bare_t<A>>::kType, names[i].ptr(), empty_class.ptr(),
                                             uint32_t(gen::PropertyHint::PROPERTY_HINT_NONE), hints[i].ptr(),
                                             uint32_t(gen::PropertyUsageFlags::PROPERTY_USAGE_DEFAULT)},
      args_meta[i] = ArgTraits<detail::bare_t<A>>::kMeta, ++i),
     ...);
    StringName ret_name;
    StringName ret_class(ret.return_enum ? ret.return_enum : "");
    GDExtensionPropertyInfo ret_info{};
    init_return_info(ret_info, ret_name, ret.return_enum ? ret_class : empty_class, hints.back());
    if (ret.return_enum) ret_info.usage |= uint32_t(gen::PropertyUsageFlags::PROPERTY_USAGE_CLASS_IS_ENUM);
    if (ret.return_array_of) {
      hints.back() = String(ret.return_array_of);
      ret_info.hint = uint32_t(gen::PropertyHint::PROPERTY_HINT_ARRAY_TYPE);
      ret_info.hint_string = hints.back().ptr();
    }

    GDExtensionClassMethodInfo mi{};
    mi.name = method_name.ptr();
    mi.method_userdata = record.get();
    mi.call_func = &detail::MethodRecord<C, R, A...>::call;
    mi.ptrcall_func = &detail::MethodRecord<C, R, A...>::ptrcall;
    mi.method_flags = GDEXTENSION_METHOD_FLAG_NORMAL | (is_const ? GDEXTENSION_METHOD_FLAG_CONST : 0);
    if constexpr (!std::is_void_v<R>) {
      mi.has_return_value = 1;
      ret_info.type = ArgTraits<detail::bare_t<R>>::kType;
      mi.return_value_info = &ret_info;
      mi.return_value_metadata = ArgTraits<detail::bare_t<R>>::kMeta;
    }
    mi.argument_count = uint32_t(sizeof...(A));
    mi.arguments_info = args_info;
    mi.arguments_metadata = args_meta;
    gde.classdb_register_extension_class_method(gde.library, record_.name.ptr(), &mi);
    record_.methods.push_back(std::move(record));
  }

 public:

  void property(const PropertySpec& spec, const char* setter, const char* getter) {
    StringName name(spec.name), class_name(spec.class_name), set(setter), get(getter);
    String hint_string(spec.hint_string);
    GDExtensionPropertyInfo info{spec.type, name.ptr(), class_name.ptr(), uint32_t(spec.hint), hint_string.ptr(),
                                 uint32_t(spec.usage)};
    gde.classdb_register_extension_class_property(gde.library, record_.name.ptr(), &info, set.ptr(), get.ptr());
  }

  // Properties registered after this line whose names start with `prefix` show under `name`.
  void group(const char* name, const char* prefix) {
    String n(name), p(prefix);
    gde.classdb_register_extension_class_property_group(gde.library, record_.name.ptr(), n.ptr(), p.ptr());
  }

  // A signal without arguments.
  void signal(const char* name) {
    StringName n(name);
    gde.classdb_register_extension_class_signal(gde.library, record_.name.ptr(), n.ptr(), nullptr, 0);
  }

  void constant(const char* enum_name, const char* name, int64_t value) {
    StringName e(enum_name), n(name);
    gde.classdb_register_extension_class_integer_constant(gde.library, record_.name.ptr(), e.ptr(), n.ptr(), value, 0);
  }

  // A virtual of the engine parent that C overrides with the member function `fn`; `hash` comes
  // from extension_api.json (gen::kVirtualHash_*), checked when the engine asks for it.
  template <class R, class... A>
  void virtual_method(const char* name, uint32_t hash, R (C::*fn)(A...)) {
    record_.virtuals.push_back(std::make_unique<detail::VirtualMethod<C, false, R, A...>>(name, hash, fn));
  }
  template <class R, class... A>
  void virtual_method(const char* name, uint32_t hash, R (C::*fn)(A...) const) {
    record_.virtuals.push_back(std::make_unique<detail::VirtualMethod<C, true, R, A...>>(name, hash, fn));
  }
  template <class B, class R, class... A, std::enable_if_t<std::is_base_of_v<B, C> && !std::is_same_v<B, C>, int> = 0>
  void virtual_method(const char* name, uint32_t hash, R (B::*fn)(A...)) {
    virtual_method(name, hash, static_cast<R (C::*)(A...)>(fn));
  }

 private:
  static void init_return_info(GDExtensionPropertyInfo& info, StringName& name, StringName& class_name,
                                          String& hint) {
    info.type = GDEXTENSION_VARIANT_TYPE_NIL;
    info.name = name.ptr();
    info.class_name = class_name.ptr();
    info.hint = uint32_t(gen::PropertyHint::PROPERTY_HINT_NONE);
    info.hint_string = hint.ptr();
    info.usage = uint32_t(gen::PropertyUsageFlags::PROPERTY_USAGE_DEFAULT);
  }

  static GDExtensionObjectPtr create_instance(void* class_userdata, GDExtensionBool notify_postinitialize) {
    auto* record = static_cast<ClassRecord*>(class_userdata);
    ObjectPtr object = gde.classdb_construct_object2(record->parent.ptr());
    if (object == nullptr) return nullptr;
    C* self = new C(object);
    gde.object_set_instance(object, record->name.ptr(), self);
    gde.object_set_instance_binding(object, gde.library, self, &kInstanceBindingCallbacks);
    // classdb_construct_object2 does not send POSTINITIALIZE: the extension must, when asked.
    if (notify_postinitialize) call(gen::Method::Object_notification, object, int64_t(0), false);
    return object;
  }

  static void free_instance(void*, GDExtensionClassInstancePtr instance) { delete static_cast<C*>(instance); }

  static GDExtensionBool validate_property(GDExtensionClassInstancePtr instance, GDExtensionPropertyInfo* property) {
    try {
      return static_cast<C*>(instance)->validate_property(*property) ? 1 : 0;
    } catch (...) {
      return 0;
    }
  }

  static void notification(GDExtensionClassInstancePtr instance, int32_t what, GDExtensionBool /*reversed*/) {
    try {
      static_cast<C*>(instance)->notification(what);
    } catch (...) {
      IKCHAIN_PRINT_ERROR("IKChain: unexpected C++ exception in a notification");
    }
  }

  static void* get_virtual_call_data(void* class_userdata, GDExtensionConstStringNamePtr name, uint32_t hash) {
    auto* record = static_cast<ClassRecord*>(class_userdata);
    for (const auto& v : record->virtuals) {
      if (!v->name.equals(name)) continue;
      if (v->hash != hash) {
        IKCHAIN_PRINT_ERROR("IKChain: virtual method hash differs from the engine's; override not installed");
        return nullptr;
      }
      return v.get();
    }
    return nullptr;
  }

  static void call_virtual_with_data(GDExtensionClassInstancePtr instance, GDExtensionConstStringNamePtr,
                                     void* data, const GDExtensionConstTypePtr* args, GDExtensionTypePtr r_ret) {
    try {
      static_cast<const VirtualRecord*>(data)->call(instance, args, r_ret);
    } catch (...) {
      IKCHAIN_PRINT_ERROR("IKChain: unexpected C++ exception in a virtual method");
    }
  }

  ClassRecord& record_;
};

}  // namespace ikchain::gdx
