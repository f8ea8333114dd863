#include "hazmap/core/yield_point.hpp"

namespace hazmap {

namespace {
thread_local const std::function<void()>* current_hook = nullptr;
}  // namespace

void yieldPoint() {
  if (current_hook) (*current_hook)();
}

ScopedYieldHook::ScopedYieldHook(std::function<void()> hook) : hook_(std::move(hook)), previous_(current_hook) {
  current_hook = &hook_;
}

ScopedYieldHook::~ScopedYieldHook() { current_hook = previous_; }

}  // namespace hazmap
