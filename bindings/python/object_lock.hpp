// Per-object locks of the Python bindings. Calls on a Mapper or a TsdfVolume run without the GIL
// (so other Python threads keep running) while holding that object's lock: readers share it,
// writers hold it alone, so two Python threads on one object take turns instead of racing on its
// OpenVDB trees. A thread that already holds an object's lock (a progress callback of a replay
// that is writing into the mapper) does not take it again.
#pragma once

#include <pybind11/pybind11.h>

#include <type_traits>
#include <utility>

namespace vdbmap::python {

enum class Access { Read, Write };

/// Holds `object`'s lock for its lifetime. Construct it only without the GIL (the holder of an
/// object's lock may need the GIL for a callback).
class ObjectLock {
 public:
  struct Entry;  ///< an object's lock while some thread holds or waits for it (object_lock.cpp)

  ObjectLock(const void* object, Access access);
  ~ObjectLock();
  ObjectLock(const ObjectLock&) = delete;
  ObjectLock& operator=(const ObjectLock&) = delete;

 private:
  const void* object_;
  Access access_;
  Entry* entry_ = nullptr;  ///< null when this thread already held the lock
};

/// Runs f() without the GIL, holding `object`'s lock; returns its result by value (so nothing
/// refers into the object once the lock is released). f must not touch Python objects.
template <typename F>
auto withLock(const void* object, Access access, F&& f) -> std::decay_t<decltype(f())> {
  pybind11::gil_scoped_release nogil;
  ObjectLock lock(object, access);
  return std::forward<F>(f)();
}

/// A binding of a const member function (or a member function) run under withLock, for .def().
template <Access A, typename C, typename R, typename... Args>
auto locked(R (C::*fn)(Args...) const) {
  return [fn](const C& self, Args... args) { return withLock(&self, A, [&] { return (self.*fn)(args...); }); };
}
template <Access A, typename C, typename R, typename... Args>
auto locked(R (C::*fn)(Args...)) {
  return [fn](C& self, Args... args) { return withLock(&self, A, [&] { return (self.*fn)(args...); }); };
}

}  // namespace vdbmap::python
