// OpenCASCADE's progress indicator passing on to ours. The algorithms that take a
// Message_ProgressRange (the mesher, sewing) poll UserBreak() as they go and stop early when it
// says so; the caller then calls ProgressSpan::step or check, which throws Cancelled.
#pragma once

#include "core/progress.h"

#include <Message_ProgressIndicator.hxx>
#include <Message_ProgressScope.hxx>

namespace idealize {

class OcctProgress : public Message_ProgressIndicator {
 public:
  explicit OcctProgress(const ProgressSpan& span) : span_(span) {}
  Standard_Boolean UserBreak() override { return span_.progress && span_.progress->cancelled(); }
  void Show(const Message_ProgressScope&, const Standard_Boolean) override {
    if (span_.progress) span_.progress->report(span_.stage, span_.start + (span_.end - span_.start) * GetPosition());
  }

 private:
  ProgressSpan span_;
};

}  // namespace idealize
