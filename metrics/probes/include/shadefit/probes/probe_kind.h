// The probes by name: parsed once where a name comes in (a study file, the command line), typed
// everywhere after (docs/probes.md). A small header so that study specs can hold probe kinds
// without the renderer's headers.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace shadefit::probes {

enum class ProbeKind { kFresnel, kHighlight, kEnergy, kPortability, kBrdf };

// Every probe, in the order the names are listed to users.
const std::vector<ProbeKind>& AllProbeKinds();

// "fresnel", "highlight", "energy", "portability", "brdf" (brdf_space.h): the name in study files, on the command
// line, in ProbeResult::probe and in output file names.
const char* ProbeName(ProbeKind kind);

// The kind of a name; nullopt for an unknown one (the caller says where it came from).
std::optional<ProbeKind> ParseProbeKind(std::string_view name);

// Every probe's name, in AllProbeKinds' order (for DidYouMean and the CLI's choices).
std::vector<std::string> ProbeNames();

}  // namespace shadefit::probes
