// trace_command.cpp -- the control protocol's `trace` command over TraceRings (docs/control-protocol.md).
#include "trace/trace_rings.hpp"

#include "variables/variable_segment.hpp"

namespace irp::trace {

Result<json> handleTraceCommand(TraceRings &rings, const variables::VariableSegment *vars,
                                const nlohmann::json &request) {
    if (!rings.header()) return Error{"trace rings are not available in this irpd"};
    auto found = request.find("channels");
    if (found == request.end()) return rings.describe();
    const nlohmann::json &list = *found;
    if (!list.is_array()) return Error{"\"channels\" must be a list of variable paths, e.g. [\"knu.Robot.tick\"]"};
    std::vector<std::string> paths;
    for (std::size_t i = 0; i < list.size(); ++i) {
        if (!list[i].is_string())
            return Error{"\"channels\"[" + std::to_string(i) + "] is " + list[i].dump() + ", not a variable path"};
        paths.push_back(list[i].get<std::string>());
    }
    auto owner = request.find("owner");
    Result<json> answer = rings.configureFor(
        owner != request.end() && owner->is_string() ? owner->get<std::string>() : "agent", paths, vars);
    if (!answer) return answer;
    if (!rings.waitApplied(rings.requestedGeneration(), kApplyWaitNs)) return answer;  // "applied": false
    return rings.describe();
}

}  // namespace irp::trace
