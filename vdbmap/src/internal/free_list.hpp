// A thread-safe free list of large heap objects (private to the library): buffers that are costly
// to allocate and clear are kept for the next use instead of being freed.
#pragma once

#include <cstddef>
#include <memory>
#include <mutex>
#include <vector>

namespace vdbmap::internal {

/// Keeps at most `capacity` objects; beyond that, kept objects are freed. Objects come back as
/// their last user left them: the caller resets what it needs.
template <typename T>
class FreeList {
 public:
  explicit FreeList(std::size_t capacity) : capacity_(capacity) {}

  /// A kept object, or nullptr when none is kept.
  std::unique_ptr<T> take() {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (kept_.empty()) return nullptr;
    std::unique_ptr<T> object = std::move(kept_.back());
    kept_.pop_back();
    return object;
  }

  /// Keeps each non-null object of `objects` while there is room (one lock for all); clears
  /// `objects`.
  void keep(std::vector<std::unique_ptr<T>>& objects) {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (std::unique_ptr<T>& object : objects)
      if (object && kept_.size() < capacity_) kept_.push_back(std::move(object));
    objects.clear();
  }
  void keep(std::unique_ptr<T> object) {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (object && kept_.size() < capacity_) kept_.push_back(std::move(object));
  }

 private:
  const std::size_t capacity_;
  std::mutex mutex_;
  std::vector<std::unique_ptr<T>> kept_;
};

}  // namespace vdbmap::internal
