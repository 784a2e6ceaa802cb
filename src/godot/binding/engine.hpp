// Calls into engine methods by ptrcall. Method binds are resolved once, at SCENE init, from the
// hashes generated out of extension_api.json (engine_api.gen.hpp); a missing one fails the load.
//
// ptrcall encoding: every integer is int64, every float is double, bool is one byte, an Object is
// passed and returned as Object* storage, builtins as raw memory of the engine's layout.
#pragma once

#include <gdextension_interface.h>

#include <cstdint>
#include <type_traits>
#include <tuple>
#include <utility>

#include "binding/builtins.hpp"
#include "binding/interface.hpp"
#include "engine_api.gen.hpp"

namespace ikchain::gdx {

bool init_method_binds();
GDExtensionMethodBindPtr method_bind(gen::Method m);

// Class tags for object_cast_to (resolved with the method binds); the enum is generated with the
// typed class wrappers (engine_classes.gen.hpp, included through binding/classes.hpp).
enum class ClassTag : int;
void* class_tag(ClassTag tag);

namespace detail {

// Wire format of one ptrcall argument or return value.
template <class T, class = void>
struct Wire {  // builtins (String, Transform3D, ...) travel as their own memory
  using type = T;
};
template <>
struct Wire<bool> {
  using type = uint8_t;
};
template <class T>
struct Wire<T, std::enable_if_t<std::is_integral_v<T> && !std::is_same_v<T, bool>>> {
  using type = int64_t;
};
template <class T>
struct Wire<T, std::enable_if_t<std::is_floating_point_v<T>>> {
  using type = double;
};
template <class T>
using wire_t = typename Wire<std::decay_t<T>>::type;

template <class T>
constexpr bool is_scalar = std::is_arithmetic_v<T> || std::is_pointer_v<T>;

// One argument: a re-encoded copy for scalars and Object pointers, the address for builtins.
template <class T, bool Scalar = is_scalar<T>>
struct ArgSlot {
  explicit ArgSlot(const T& v) : value(&v) {}
  GDExtensionConstTypePtr ptr() const { return value; }
  const T* value;
};
template <class T>
struct ArgSlot<T, true> {
  explicit ArgSlot(const T& v) : value(static_cast<wire_t<T>>(v)) {}
  GDExtensionConstTypePtr ptr() const { return &value; }
  wire_t<T> value;
};

template <class R, class... A, size_t... I>
R call_impl(GDExtensionMethodBindPtr bind, ObjectPtr object, std::index_sequence<I...>, const A&... args) {
  const std::tuple<ArgSlot<A>...> slots{ArgSlot<A>{args}...};
  const GDExtensionConstTypePtr arg_ptrs[sizeof...(A) + 1] = {std::get<I>(slots).ptr()..., nullptr};
  if constexpr (std::is_void_v<R>) {
    gde.object_method_bind_ptrcall(bind, object, arg_ptrs, nullptr);
  } else if constexpr (is_scalar<R>) {
    wire_t<R> ret{};
    gde.object_method_bind_ptrcall(bind, object, arg_ptrs, &ret);
    if constexpr (std::is_same_v<R, bool>) {
      return ret != 0;
    } else {
      return static_cast<R>(ret);
    }
  } else {
    R ret{};  // the engine assigns into a constructed value
    gde.object_method_bind_ptrcall(bind, object, arg_ptrs, &ret);
    return ret;
  }
}

}  // namespace detail

// call<R>(Method, object, args...): R is void, a scalar (bool, an integer, double), ObjectPtr or
// one of our builtins. The method's signature is the one recorded in extension_api.json. Only the
// generated wrappers (engine_classes.gen.hpp) call this: code uses the typed member functions.
template <class R = void, class... A>
R call(gen::Method m, ObjectPtr object, const A&... args) {
  return detail::call_impl<R>(method_bind(m), object, std::index_sequence_for<A...>{}, args...);
}

}  // namespace ikchain::gdx
