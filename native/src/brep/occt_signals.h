// Faults inside OpenCASCADE as C++ exceptions.
//
// OCCT's healing, checking and meshing dereference null pointers on some inputs. With its signal
// handlers installed (OSD::SetSignal) a fault jumps to the nearest OCC_CATCH_SIGNALS, which throws
// a Standard_Failure (Debian's OCCT is built with OCC_CONVERT_SIGNALS, and so must be the code
// using the macro): the user's FreeCAD gets an error message instead of a crash.
#pragma once

#include <OSD.hxx>
#include <Standard_ErrorHandler.hxx>

#include <array>
#include <csignal>

namespace idealize {

// OCCT's signal handlers while alive; the process's own ones (Python's, FreeCAD's) before and
// after, so that Ctrl-C in Python keeps working outside OCCT calls.
class OcctSignalHandlers {
 public:
  OcctSignalHandlers() {
    for (int signal = 1; signal < kSignals; ++signal) sigaction(signal, nullptr, &saved_[signal]);
    OSD::SetSignal(OSD_SignalMode_Set, Standard_False);
  }
  ~OcctSignalHandlers() {
    for (int signal = 1; signal < kSignals; ++signal) sigaction(signal, &saved_[signal], nullptr);
  }
  OcctSignalHandlers(const OcctSignalHandlers&) = delete;
  OcctSignalHandlers& operator=(const OcctSignalHandlers&) = delete;

 private:
  static constexpr int kSignals = 32;
  std::array<struct sigaction, kSignals> saved_{};
};

}  // namespace idealize
