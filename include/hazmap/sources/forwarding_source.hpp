#pragma once
// A source passing every call on to another: a wrapper derives from it and overrides what it
// changes (next(), typically: a start made unknown, a stream watched or paced).
#include <memory>

#include "hazmap/sources/scan_source.hpp"

namespace hazmap {

class ForwardingScanSource : public ScanSource {
 public:
  explicit ForwardingScanSource(std::unique_ptr<ScanSource> inner) : inner_(std::move(inner)) {}
  std::optional<Scan> next() override { return inner_->next(); }
  std::optional<std::size_t> size() const override { return inner_->size(); }
  const ClassTable& classTable() const override { return inner_->classTable(); }
  std::string describe() const override { return inner_->describe(); }
  bool canReread() const override { return inner_->canReread(); }
  LabeledCloud reread(std::size_t index) const override { return inner_->reread(index); }

 private:
  std::unique_ptr<ScanSource> inner_;
};

}  // namespace hazmap
