#pragma once
// The one place where exceptions become exit codes (only main() calls this).
#include <exception>
#include <iostream>
#include <string>

#include "mesorock/errors.h"

namespace mesorock::pipeline {

enum ExitCode : int {
  kExitOk = 0,
  kExitFailed = 1,         // a validation quantity failed, or an unexpected internal error
  kExitBadInput = 2,       // bad usage, bad file, missing backend
  kExitNumerical = 3,      // the run blew up (NaN, runaway velocity): a diagnostic was printed
  kExitInterrupted = 130,  // Ctrl-C or SIGTERM (128 + SIGINT, the shell's convention)
};

// Runs body(); prints "<tool>: error: <message>" on one line and returns the exit code.
template <class Body>
int run_main(const char* tool, Body&& body) {
  try {
    return body();
  } catch (const ConfigError& e) {
    std::cerr << tool << ": error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const IoError& e) {
    std::cerr << tool << ": error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const DeviceError& e) {
    std::cerr << tool << ": error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const LimitError& e) {
    std::cerr << tool << ": error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const Interrupted& e) {
    std::cerr << tool << ": interrupted: " << e.what() << "\n";
    return kExitInterrupted;
  } catch (const NumericalError& e) {
    std::cerr << tool << ": numerical failure: " << e.what() << "\n";
    return kExitNumerical;
  } catch (const std::bad_alloc&) {
    std::cerr << tool << ": error: out of memory\n";
    return kExitFailed;
  } catch (const std::exception& e) {
    std::cerr << tool << ": internal error: " << e.what() << "\n";
    return kExitFailed;
  }
}

}  // namespace mesorock::pipeline
