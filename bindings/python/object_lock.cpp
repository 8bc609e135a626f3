#include "object_lock.hpp"

#include <algorithm>
#include <mutex>
#include <shared_mutex>
#include <unordered_map>
#include <vector>

namespace vdbmap::python {

/// An object's lock, alive while some thread holds or waits for it.
struct ObjectLock::Entry {
  std::shared_mutex mutex;
  int users = 0;
};

namespace {

std::mutex g_registry_mutex;
std::unordered_map<const void*, ObjectLock::Entry*>& registry() {
  static std::unordered_map<const void*, ObjectLock::Entry*> entries;
  return entries;
}
/// Objects whose lock this thread holds.
thread_local std::vector<const void*> t_held;

}  // namespace

ObjectLock::ObjectLock(const void* object, Access access) : object_(object), access_(access) {
  if (std::find(t_held.begin(), t_held.end(), object) != t_held.end()) return;
  {
    std::lock_guard<std::mutex> guard(g_registry_mutex);
    Entry*& e = registry()[object];
    if (!e) e = new Entry;
    ++e->users;
    entry_ = e;
  }
  if (access == Access::Write)
    entry_->mutex.lock();
  else
    entry_->mutex.lock_shared();
  t_held.push_back(object);
}

ObjectLock::~ObjectLock() {
  if (!entry_) return;
  t_held.erase(std::find(t_held.begin(), t_held.end(), object_));
  if (access_ == Access::Write)
    entry_->mutex.unlock();
  else
    entry_->mutex.unlock_shared();
  std::lock_guard<std::mutex> guard(g_registry_mutex);
  if (--entry_->users == 0) {
    registry().erase(object_);
    delete entry_;
  }
}

}  // namespace vdbmap::python
