#pragma once
// Fuzz harness of the scene parser (pipeline/scene.h parse_scene): a scene is accepted or refused
// with a ConfigError/IoError whose message is one line; any other exception, a crash, a sanitizer
// report or a hang is a defect. Called by the libFuzzer target (tests/fuzz/fuzz_scene.cpp) and by
// the normal build's replay of the crashes found (tests/unit/pipeline/test_fuzz_regressions.cpp).
#include <cstdint>
#include <stdexcept>
#include <string>

#include "mesorock/errors.h"
#include "pipeline/scene.h"

namespace mesorock::fuzz {

inline void fuzz_scene(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::string message;
  try {
    const pipeline::Scene scene = pipeline::parse_scene(text, "fuzz.toml");
    for (const auto& stage : scene.stages) (void)pipeline::stage_is_averaged(scene, stage.name);
    return;
  } catch (const ConfigError& e) {
    message = e.what();
  } catch (const IoError& e) {
    message = e.what();
  }
  if (message.find('\n') != std::string::npos)
    throw std::logic_error("error message spans several lines: " + message);
  if (message.rfind("fuzz.toml", 0) != 0)
    throw std::logic_error("error message does not start with the file name: " + message);
}

}  // namespace mesorock::fuzz
