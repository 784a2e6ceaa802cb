// A minimal non-owning view (C++17 has no std::span). Used for goals and joint arrays so the
// per-frame API takes caller-owned memory and allocates nothing.
#pragma once
#include <cstddef>
#include <type_traits>
#include <utility>

namespace ikchain {

template <typename T>
struct Span {
  T* data = nullptr;
  int size = 0;

  constexpr Span() = default;
  constexpr Span(T* d, int n) : data(d), size(n) {}
  // From any contiguous container (std::vector, std::array): implicit on purpose.
  template <typename Container,
            typename = std::enable_if_t<!std::is_same<std::decay_t<Container>, Span>::value>,
            typename = decltype(std::declval<Container&>().data())>
  Span(Container& c) : data(c.data()), size(static_cast<int>(c.size())) {}  // NOLINT
  // A Span<const T> from a Span<T>.
  template <typename U, typename = std::enable_if_t<std::is_convertible<U*, T*>::value>>
  constexpr Span(const Span<U>& other) : data(other.data), size(other.size) {}  // NOLINT

  T& operator[](int i) const { return data[i]; }
  T* begin() const { return data; }
  T* end() const { return data + size; }
  bool empty() const { return size == 0; }
};

}  // namespace ikchain
