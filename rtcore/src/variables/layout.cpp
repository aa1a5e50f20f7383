// layout.cpp -- layout.json parsing and checks (nlohmann::json).
#include "variables/layout.hpp"

#include <nlohmann/json.hpp>

#include <map>

#include <fstream>
#include <sstream>

namespace irp::variables {

Result<Layout> readLayout(const std::filesystem::path &path) {
    const std::string file = path.string();
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        return fileError(file, "no such layout file (glbc writes it: glbc FILE.glb -o DIR)");
    if (std::filesystem::file_size(path, ec) > kMaxLayoutBytes)
        return fileError(file, "larger than 64 MiB; not a layout");
    std::ifstream in(path, std::ios::binary);
    std::ostringstream buffer;
    buffer << in.rdbuf();
    Layout layout;
    layout.path = path;
    layout.text = buffer.str();

    nlohmann::json j;
    try {
        j = nlohmann::json::parse(layout.text);
    } catch (const nlohmann::json::exception &e) {
        return fileError(file, std::string("not valid JSON: ") + e.what());
    }
    try {
        if (!j.is_object() || j.value("format", "") != "indurop-layout")
            return fileError(file, "not an indurop layout (\"format\" is not \"indurop-layout\")");
        if (j.at("version").get<int>() != 1)
            return fileError(file, "layout version " + j.at("version").dump() + "; this irpd reads version 1");
        layout.hash = j.at("hash").get<std::string>();
        if (layout.hash.size() != 64 || layout.hash.find_first_not_of("0123456789abcdef") != std::string::npos)
            return fileError(file, "\"hash\" is not 64 lower-case hex digits");
        layout.data_size = j.at("data_size").get<uint64_t>();
        if (layout.data_size % 64 || layout.data_size > kMaxDataSize)
            return fileError(file, "\"data_size\" " + std::to_string(layout.data_size) +
                                       " is not a multiple of 64 up to 1 GiB");
        layout.lock_count = j.at("lock_count").get<uint32_t>();
        const auto &variables = j.at("variables");
        // lock_count may exceed the locks the variables use: a layout laid out against a running one
        // (glbc --previous) keeps the locks of removed variables as holes.  Variables share a lock
        // only as the members of one lock group ("lock_group").
        if (!variables.is_array()) return fileError(file, "\"variables\" is not a list");
        std::map<uint64_t, std::string> locks;  // the lock -> its group ("" for a variable's own)
        for (const auto &v : variables) {
            const auto path_name = v.at("path").get<std::string>();
            const auto offset = v.at("offset").get<uint64_t>(), size = v.at("size").get<uint64_t>();
            const auto lock = v.at("lock").get<uint64_t>();
            if (offset + size > layout.data_size || offset + size < offset)
                return fileError(file, "variable " + path_name + " lies outside the data area");
            if (lock >= layout.lock_count)
                return fileError(file, "variable " + path_name + " names lock " + std::to_string(lock));
            const auto group = v.value("lock_group", std::string{});
            if (auto [at, fresh] = locks.emplace(lock, group); !fresh && (group.empty() || at->second != group))
                return fileError(file, "variable " + path_name + " shares lock " + std::to_string(lock) +
                                           " with another variable outside its lock group");
        }
        layout.variables = variables.size();
    } catch (const nlohmann::json::exception &e) {
        return fileError(file, std::string("malformed layout: ") + e.what());
    }
    std::string problem;
    auto model = layouts::fromJson(j, problem);
    if (!model) return fileError(file, problem);
    layout.model = std::move(*model);
    return layout;
}

}  // namespace irp::variables
