// module_xml.cpp -- reads module.xml with pugixml and validates every field into a SetSpec.
//
// The document is parsed without entity expansion: pugixml has no DTD support, DOCTYPE is refused
// outright, and escapes are decoded here so that anything but the five predefined entities and
// numeric character references is reported instead of passed through.
#include "config/module_xml.hpp"

#include "protocol/limits.hpp"
#include "sdk/alarm_rules.hpp"

#include <pugixml.hpp>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace irp::config {

const char *toString(ModuleType type) { return type == ModuleType::Thread ? "thread" : "process"; }

const char *toString(OperationType type) {
    switch (type) {
    case OperationType::Periodic: return "periodic";
    case OperationType::Sporadic: return "sporadic";
    case OperationType::NonReal: return "non-real";
    }
    return "?";
}

const char *toString(OverrunAction action) {
    static const char *const names[] = {"none", "warn", "skip", "disable", "stop", "restart"};
    return names[static_cast<int>(action)];
}

Error errorAbout(const ModuleSpec &m, const std::string &what, std::string field) {
    return Error{m.where + ": module '" + m.name + "': " + what, protocol::kRefused,
                 Place{m.xml, m.line, 0, m.name, std::move(field)}};
}

namespace {

// Thrown inside the parser only, turned into an Error at its door.
struct ParseFailure {
    std::string message;
    Place place;
};

class Parser {
public:
    Parser(std::string_view text, std::filesystem::path xml_path) : text_(text), shown_(xml_path.string()) {
        std::error_code ec;
        auto absolute = std::filesystem::absolute(xml_path, ec);
        path_ = ec ? xml_path : absolute.lexically_normal();
    }

    SetSpec run() {
        pugi::xml_document doc;
        // parse_fragment keeps text outside <root> so that it can be refused; parse_pi keeps
        // processing instructions for the same reason.
        const unsigned options = (pugi::parse_default | pugi::parse_doctype | pugi::parse_declaration | pugi::parse_pi |
                                  pugi::parse_fragment) &
                                 ~pugi::parse_escapes;
        pugi::xml_parse_result parsed = doc.load_buffer(text_.data(), text_.size(), options, pugi::encoding_utf8);
        if (!parsed)
            fail(static_cast<std::ptrdiff_t>(parsed.offset), std::string("malformed XML: ") + parsed.description());

        pugi::xml_node root;
        for (pugi::xml_node node : doc.children()) {
            switch (node.type()) {
            case pugi::node_doctype:
                fail(node, "a DOCTYPE is not allowed in module.xml (no DTDs, so no entity definitions)");
            case pugi::node_element:
                if (root)
                    fail(node,
                         "a second top-level element <" + std::string(node.name()) + ">; module.xml has one <root>");
                root = node;
                break;
            case pugi::node_pcdata:
            case pugi::node_cdata:
                skippable(node);  // whitespace passes, text is refused
                break;
            case pugi::node_pi:
                fail(node, "processing instruction <?" + std::string(node.name()) + "?> is not allowed");
            default: break;  // declaration
            }
        }
        if (!root) fail(0, "no <root> element");
        if (std::string_view(root.name()) != "root")
            fail(root, "the top-level element is <" + std::string(root.name()) + ">, expected <root>");
        noAttributes(root);

        SetSpec set;
        set.xml_path = path_;
        for (pugi::xml_node node : root.children()) {
            module_.clear();
            if (skippable(node)) continue;
            std::string_view tag = node.name();
            if (tag == "module") {
                if (set.modules.size() >= kMaxModules)
                    fail(node, "more than " + std::to_string(kMaxModules) + " modules in one set");
                set.modules.push_back(module(node, static_cast<int>(set.modules.size())));
            } else if (tag == "executor") {
                set.executors.push_back(executor(node));
            } else if (tag == "layout") {
                if (!set.layout.empty()) fail(node, "<layout> appears twice in <root>");
                std::string file = leafText(node, "");
                if (file.empty()) fail(node, "<layout> is empty; expected the set's layout.json (written by glbc)");
                if (file.find('\0') != std::string::npos) fail(node, "<layout> contains a NUL");
                std::filesystem::path p(file);
                set.layout = p.is_absolute() ? p.lexically_normal() : (path_.parent_path() / p).lexically_normal();
                set.layout_line = lineOf(node);
            } else {
                fail(node,
                     "unknown tag <" + std::string(tag) + "> in <root>; expected <module>, <executor> or <layout>");
            }
        }
        module_.clear();
        crossCheck(set);
        return set;
    }

private:
    // ---- messages ---------------------------------------------------------------------------
    int lineAt(std::ptrdiff_t offset) const {
        if (offset < 0) return 0;
        auto end = text_.begin() + std::min<std::ptrdiff_t>(offset, static_cast<std::ptrdiff_t>(text_.size()));
        return 1 + static_cast<int>(std::count(text_.begin(), end, '\n'));
    }
    int lineOf(pugi::xml_node node) const { return lineAt(node.offset_debug()); }
    // The column (from 1) of offset in its line.
    int columnAt(std::ptrdiff_t offset) const {
        if (offset < 0) return 0;
        const auto at = std::min<std::size_t>(static_cast<std::size_t>(offset), text_.size());
        const auto newline = at == 0 ? std::string_view::npos : text_.rfind('\n', at - 1);
        return static_cast<int>(at - (newline == std::string_view::npos ? 0 : newline + 1)) + 1;
    }
    // Where a node starts: an element's offset is its name's, so one back is its '<'.
    std::ptrdiff_t offsetOf(pugi::xml_node node) const {
        std::ptrdiff_t offset = node.offset_debug();
        if (node.type() == pugi::node_element && offset > 0 && offset <= static_cast<std::ptrdiff_t>(text_.size()) &&
            text_[static_cast<std::size_t>(offset - 1)] == '<')
            --offset;
        return offset;
    }

    // The module.xml field a node is in: the element under <module> or <executor> that holds it,
    // "property.NAME" inside a <property>'s <value name="NAME">.
    static std::string fieldOf(pugi::xml_node node) {
        std::string value_name;
        for (pugi::xml_node n = node; n && n.parent(); n = n.parent()) {
            const std::string_view parent = n.parent().name();
            if (std::string_view(n.name()) == "value" && parent == "property") value_name = n.attribute("name").value();
            if (n.type() == pugi::node_element && (parent == "module" || parent == "executor"))
                return value_name.empty() ? n.name() : std::string(n.name()) + "." + value_name;
        }
        return {};
    }

    // The place of an error on `line`, with the column of offset when offset is on that line.
    Place placeAt(std::ptrdiff_t offset, int line, std::string field) const {
        return Place{path_.string(), line, line == lineAt(offset) ? columnAt(offset) : 0, module_, std::move(field)};
    }

    [[noreturn]] void fail(std::ptrdiff_t offset, const std::string &what) const {
        const int line = lineAt(offset);
        throw ParseFailure{shown_ + ":" + std::to_string(line) + ": " + what, placeAt(offset, line, {})};
    }
    [[noreturn]] void fail(pugi::xml_node node, const std::string &what, std::string field = {}) const {
        const std::ptrdiff_t offset = offsetOf(node);
        const int line = lineAt(offset);
        throw ParseFailure{shown_ + ":" + std::to_string(line) + ": " + what,
                           placeAt(offset, line, field.empty() ? fieldOf(node) : std::move(field))};
    }
    // For position i of the text (value) of node: text nodes start right after the previous tag,
    // so the line of the offending character is the node's line plus the newlines before it.
    [[noreturn]] void failInText(pugi::xml_node node, std::string_view text, std::size_t i,
                                 const std::string &what) const {
        const int line =
            lineOf(node) + static_cast<int>(std::count(text.begin(), text.begin() + std::min(i, text.size()), '\n'));
        throw ParseFailure{shown_ + ":" + std::to_string(line) + ": " + what,
                           placeAt(node.offset_debug() + static_cast<std::ptrdiff_t>(i), line, fieldOf(node))};
    }
    // For a field of a module: "file:line: module 'cntr1': <period>: what"
    [[noreturn]] void failField(pugi::xml_node node, const std::string &module, const std::string &field,
                                const std::string &what) const {
        std::string in = fieldOf(node);  // more precise where it names a property
        fail(node, (module.empty() ? std::string() : owner_kind_ + " '" + module + "': ") + "<" + field + ">: " + what,
             in.empty() ? field : std::move(in));
    }
    // For the whole of a module or executor, found by the whole-set checks.
    [[noreturn]] void failOwner(int line, const std::string &owner, const std::string &what) const {
        throw ParseFailure{shown_ + ":" + std::to_string(line) + ": " + what,
                           Place{path_.string(), line, 0, owner, {}}};
    }

    // ---- node helpers -----------------------------------------------------------------------
    bool skippable(pugi::xml_node node) const {
        if (node.type() == pugi::node_comment) return true;
        if (node.type() == pugi::node_pcdata || node.type() == pugi::node_cdata) {
            std::string_view v = node.value();
            auto first = v.find_first_not_of(" \t\r\n");
            if (first == std::string_view::npos) return true;
            failInText(node, v, first, "unexpected text '" + std::string(trim(v)) + "' between elements");
        }
        if (node.type() == pugi::node_pi)
            fail(node, "processing instruction <?" + std::string(node.name()) + "?> is not allowed");
        return false;
    }

    void noAttributes(pugi::xml_node node) const {
        if (pugi::xml_attribute a = node.first_attribute())
            fail(node, "unknown attribute '" + std::string(a.name()) + "' on <" + node.name() + ">");
    }

    static std::string_view trim(std::string_view v) {
        auto b = v.find_first_not_of(" \t\r\n");
        if (b == std::string_view::npos) return {};
        auto e = v.find_last_not_of(" \t\r\n");
        return v.substr(b, e - b + 1);
    }

    // Decodes &lt; &gt; &amp; &apos; &quot; &#N; &#xN;; anything else is an error.
    std::string unescape(pugi::xml_node at, std::string_view raw) const {
        std::string out;
        out.reserve(raw.size());
        for (std::size_t i = 0; i < raw.size(); ++i) {
            if (raw[i] != '&') {
                out += raw[i];
                continue;
            }
            auto semi = raw.find(';', i);
            if (semi == std::string_view::npos || semi - i > 12)
                failInText(at, raw, i, "a bare '&' in text; write it as &amp;");
            std::string_view name = raw.substr(i + 1, semi - i - 1);
            if (name == "lt")
                out += '<';
            else if (name == "gt")
                out += '>';
            else if (name == "amp")
                out += '&';
            else if (name == "apos")
                out += '\'';
            else if (name == "quot")
                out += '"';
            else if (name.size() > 1 && name[0] == '#') {
                bool hex = name[1] == 'x';
                std::string_view digits = name.substr(hex ? 2 : 1);
                unsigned long code = 0;
                auto [p, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), code, hex ? 16 : 10);
                if (ec != std::errc() || p != digits.data() + digits.size() || code == 0 || code > 0x10FFFF ||
                    (code >= 0xD800 && code <= 0xDFFF))
                    failInText(at, raw, i, "bad character reference '&" + std::string(name) + ";'");
                appendUtf8(out, static_cast<uint32_t>(code));
            } else {
                failInText(
                    at, raw, i,
                    "entity reference '&" + std::string(name) +
                        ";' is not allowed: module.xml has no DTD; only &lt; &gt; &amp; &apos; &quot; and &#N; work");
            }
            i = semi;
        }
        return out;
    }

    static void appendUtf8(std::string &out, uint32_t c) {
        if (c < 0x80) {
            out += static_cast<char>(c);
        } else if (c < 0x800) {
            out += static_cast<char>(0xC0 | (c >> 6));
            out += static_cast<char>(0x80 | (c & 0x3F));
        } else if (c < 0x10000) {
            out += static_cast<char>(0xE0 | (c >> 12));
            out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
            out += static_cast<char>(0x80 | (c & 0x3F));
        } else {
            out += static_cast<char>(0xF0 | (c >> 18));
            out += static_cast<char>(0x80 | ((c >> 12) & 0x3F));
            out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
            out += static_cast<char>(0x80 | (c & 0x3F));
        }
    }

    // The text of node's children, unescaped, CDATA as it is, comments left out; an element among
    // them goes to `element` (the caller refuses it in its own words).
    std::string mixedText(pugi::xml_node node, pugi::xml_node &element) const {
        std::string raw;
        for (pugi::xml_node child : node.children()) {
            if (child.type() == pugi::node_pcdata)
                raw += unescape(child, child.value());
            else if (child.type() == pugi::node_cdata)
                raw += child.value();
            else if (child.type() != pugi::node_comment && !element)
                element = child;
        }
        return raw;
    }

    // The text of a leaf element such as <period>100000</period>, unescaped and trimmed.
    std::string leafText(pugi::xml_node node, const std::string &module) const {
        noAttributes(node);
        pugi::xml_node element;
        std::string raw = mixedText(node, element);
        if (element)
            failField(node, module, node.name(), "expected plain text, found <" + std::string(element.name()) + ">");
        return std::string(trim(raw));
    }

    int64_t integer(pugi::xml_node node, const std::string &module, const std::string &text, int64_t min,
                    const char *unit) const {
        int64_t value = 0;
        auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
        if (text.empty()) failField(node, module, node.name(), std::string("is empty; expected an integer") + unit);
        if (ec == std::errc::result_out_of_range)
            failField(node, module, node.name(),
                      "'" + text + "' is too large; expected an integer" + unit + " below 2^63");
        if (ec != std::errc() || p != text.data() + text.size())
            failField(node, module, node.name(), "'" + text + "' is not an integer; expected an integer" + unit);
        if (value < min)
            failField(node, module, node.name(),
                      "'" + text + "' must be " + (min == 1 ? "greater than 0" : "at least " + std::to_string(min)));
        return value;
    }

    // ---- <module> ---------------------------------------------------------------------------
    ModuleSpec module(pugi::xml_node node, int index) {
        ModuleSpec m;
        m.index = index;
        m.line = lineOf(node);
        module_.clear();
        m.where = shown_ + ":" + std::to_string(m.line);
        m.xml = path_.string();

        // Structural problems are reported after the name is known, so that they can name it.
        pugi::xml_node problem;
        std::string problem_text;
        auto defer = [&](pugi::xml_node at, std::string what) {
            if (!problem) problem = at, problem_text = std::move(what);
        };
        if (pugi::xml_attribute a = node.first_attribute())
            defer(node, "unknown attribute '" + std::string(a.name()) + "' on <module>");
        std::map<std::string, pugi::xml_node> fields;
        std::vector<pugi::xml_node> alarm_nodes;   // <alarm>: several allowed
        std::vector<pugi::xml_node> writes_nodes;  // <writes>: several allowed
        for (pugi::xml_node child : node.children()) {
            if (skippable(child)) continue;
            std::string tag = child.name();
            static const std::set<std::string> known = {
                "filename", "moduletype", "operationtype", "period",     "deadline",      "priority", "property",
                "name",     "budget",     "executor",      "on_overrun", "overrun_limit", "on_crash"};
            if (tag == "alarm")
                alarm_nodes.push_back(child);
            else if (tag == "writes")
                writes_nodes.push_back(child);
            else if (!known.count(tag))
                defer(child,
                      "unknown tag <" + tag +
                          "> in <module>; expected one of filename, moduletype, "
                          "operationtype, period, deadline, priority, property, name, budget, executor, on_overrun, "
                          "overrun_limit, on_crash, alarm, writes");
            else if (fields.count(tag))
                defer(child, "<" + tag + "> appears twice in one <module>");
            else
                fields[tag] = child;
        }

        auto field = [&](const char *tag) -> pugi::xml_node {
            auto it = fields.find(tag);
            return it == fields.end() ? pugi::xml_node() : it->second;
        };

        // The name first, so that every later message can say which module it is about.
        if (pugi::xml_node f = field("filename")) m.filename = leafText(f, "");
        if (pugi::xml_node f = field("name")) {
            m.name = leafText(f, "");
            if (m.name.empty()) failField(f, "", "name", "is empty");
        } else if (!m.filename.empty()) {
            m.name = std::filesystem::path(m.filename).stem().string();
        }
        module_ = m.name;
        if (problem) fail(problem, (m.name.empty() ? std::string() : "module '" + m.name + "': ") + problem_text);
        if (!field("filename")) fail(node, "<module> without <filename>");
        if (m.filename.empty()) failField(field("filename"), m.name, "filename", "is empty");
        if (m.filename.find('\0') != std::string::npos)
            failField(field("filename"), m.name, "filename", "contains a NUL");
        checkName(field("name") ? field("name") : field("filename"), m.name);
        std::filesystem::path file(m.filename);
        m.path = file.is_absolute() ? file.lexically_normal() : (path_.parent_path() / file).lexically_normal();
        m.set_dir = std::filesystem::absolute(path_.parent_path()).lexically_normal().string();

        pugi::xml_node type = field("moduletype");
        if (!type) fail(node, "module '" + m.name + "': <moduletype> is missing; expected thread or process");
        std::string t = leafText(type, m.name);
        if (t == "thread")
            m.type = ModuleType::Thread;
        else if (t == "process")
            m.type = ModuleType::Process;
        else
            failField(type, m.name, "moduletype", "unknown value '" + t + "'; expected thread or process");

        pugi::xml_node op = field("operationtype");
        if (!op)
            fail(node, "module '" + m.name + "': <operationtype> is missing; expected periodic, sporadic or non-real");
        std::string o = leafText(op, m.name);
        if (o == "periodic")
            m.operation = OperationType::Periodic;
        else if (o == "sporadic")
            m.operation = OperationType::Sporadic;
        else if (o == "non-real")
            m.operation = OperationType::NonReal;
        else
            failField(op, m.name, "operationtype",
                      "unknown value '" + o + "'; expected periodic, sporadic or non-real");

        const char *ns = " number of nanoseconds";
        pugi::xml_node period = field("period");
        pugi::xml_node deadline = field("deadline");
        pugi::xml_node priority = field("priority");
        switch (m.operation) {
        case OperationType::Periodic:
            if (!period)
                fail(node, "module '" + m.name + "': <period> is missing; a periodic module needs one (in ns)");
            m.period_ns = integer(period, m.name, leafText(period, m.name), 1, ns);
            break;
        case OperationType::Sporadic:
            if (period) failField(period, m.name, "period", "a sporadic module has a <deadline>, not a <period>");
            if (!deadline)
                fail(node, "module '" + m.name + "': <deadline> is missing; a sporadic module needs one (in ns)");
            break;
        case OperationType::NonReal:
            if (period)
                failField(period, m.name, "period", "a non-real module runs in left-over time and has no <period>");
            if (deadline) failField(deadline, m.name, "deadline", "a non-real module has no <deadline>");
            break;
        }
        if (deadline) {
            m.deadline_ns = integer(deadline, m.name, leafText(deadline, m.name), 1, ns);
            if (m.period_ns && m.deadline_ns > m.period_ns)
                failField(deadline, m.name, "deadline",
                          std::to_string(m.deadline_ns) + " is longer than the period " + std::to_string(m.period_ns));
        }
        if (priority) {
            // The range is the control protocol's (protocol/control.json), so that `set_priority` and
            // `change` accept what module.xml does.
            const std::string highest = " (" + std::to_string(protocol::kPriorityMin) + " = highest priority)";
            int64_t p = integer(priority, m.name, leafText(priority, m.name), protocol::kPriorityMin, highest.c_str());
            if (p > protocol::kPriorityMax)
                failField(priority, m.name, "priority",
                          "'" + std::to_string(p) + "' is above " + std::to_string(protocol::kPriorityMax));
            m.priority = static_cast<int>(p);
        } else if (m.operation != OperationType::NonReal) {
            fail(node, "module '" + m.name + "': <priority> is missing; the lowest value is the highest priority");
        }

        if (pugi::xml_node budget = field("budget")) {
            m.budget_ns = integer(budget, m.name, leafText(budget, m.name), 1, ns);
            if (m.operation != OperationType::Periodic)
                failField(budget, m.name, "budget", "only periodic modules have an execution budget");
            if (m.budget_ns > m.period_ns)
                failField(budget, m.name, "budget", "longer than the period " + std::to_string(m.period_ns));
        }
        if (pugi::xml_node f = field("on_crash")) {  // docs/supervision.md
            const std::string v = leafText(f, m.name);
            if (v == "restart")
                m.on_crash = CrashPolicy::Restart;
            else if (v != "exclude")
                failField(f, m.name, "on_crash", "'" + v + "'; expected exclude or restart");
            if (m.type != ModuleType::Thread)
                failField(f, m.name, "on_crash", "only thread modules (a process's crash is its own)");
        }
        if (pugi::xml_node executor = field("executor")) {
            m.executor = leafText(executor, m.name);
            if (m.executor.empty()) failField(executor, m.name, "executor", "is empty");
            executor_refs_.emplace_back(m.executor, executor);
            executor_ref_module_.push_back(m.name);
        }
        overrunWatchdog(field("on_overrun"), field("overrun_limit"), m);
        if (pugi::xml_node props = field("property")) properties(props, m);
        for (pugi::xml_node a : alarm_nodes) alarm(a, m);
        // <writes>PATH</writes>: a shared variable this module writes, declared so that a second
        // writer (the DDS bridge's mapping, docs/dds.md) is refused when the set is loaded.
        for (pugi::xml_node w : writes_nodes) {
            std::string path = leafText(w, m.name);
            if (path.empty())
                failField(w, m.name, "writes",
                          "is empty; name the shared variable the module writes, e.g. knu.Robot.tick");
            if (std::find(m.writes.begin(), m.writes.end(), path) != m.writes.end())
                failField(w, m.name, "writes", "'" + path + "' is declared twice");
            m.writes.push_back(std::move(path));
        }
        return m;
    }

    // <alarm id="N" severity="low|medium|high|critical">text</alarm> (docs/alarms.md): the id
    // 1 .. 1023 and unique in the module, the severity medium unless given, the text one line of
    // 1 .. alarm_text_max characters (its whitespace runs, newlines included, become one space).
    void alarm(pugi::xml_node node, ModuleSpec &m) {
        AlarmSpec a;
        a.line = lineOf(node);
        std::string field = "alarm";
        auto refuse = [&](const std::string &what) {
            fail(node,
                 "module '" + m.name + "': <alarm" + (a.id ? " id=\"" + std::to_string(a.id) + "\"" : "") +
                     ">: " + what,
                 field);
        };
        std::string id_text, severity_text;
        bool has_id = false, has_severity = false;
        for (pugi::xml_attribute attr : node.attributes()) {
            const std::string_view name = attr.name();
            if (name == "id" && !has_id)
                id_text = unescape(node, attr.value()), has_id = true;
            else if (name == "severity" && !has_severity)
                severity_text = unescape(node, attr.value()), has_severity = true;
            else if (name == "id" || name == "severity")
                refuse(std::string(name) + "=\"...\" appears twice");
            else
                refuse("unknown attribute '" + std::string(name) + "'; expected id=\"1..." +
                       std::to_string(INDUROP_ALARM_ID_MAX) + "\" and severity=\"low|medium|high|critical\"");
        }
        if (!has_id)
            refuse("id=\"...\" is missing; expected an alarm id from 1 to " + std::to_string(INDUROP_ALARM_ID_MAX));
        uint64_t id = 0;
        auto [end, ec] = std::from_chars(id_text.data(), id_text.data() + id_text.size(), id);
        if (ec != std::errc() || end != id_text.data() + id_text.size() || !alarm_rules::validId(id))
            refuse("id '" + id_text + "' is not an alarm id; expected an integer from 1 to " +
                   std::to_string(INDUROP_ALARM_ID_MAX));
        a.id = static_cast<uint32_t>(id);
        field = "alarm." + std::to_string(a.id);
        for (const AlarmSpec &other : m.alarms)
            if (other.id == a.id)
                refuse("alarm " + id_text + " is declared twice in the module (also at line " +
                       std::to_string(other.line) + "); ids are unique per module");
        if (has_severity) {
            const auto severity = alarm_rules::severityNamed(severity_text);
            if (!severity) refuse("severity '" + severity_text + "'; expected low, medium, high or critical");
            a.severity = *severity;
        }
        pugi::xml_node element;
        const std::string raw = mixedText(node, element);
        if (element) refuse("expected the alarm's text, found <" + std::string(element.name()) + ">");
        for (char c : raw) {  // whitespace runs (a text wrapped over lines) become one space
            const bool space = c == ' ' || c == '\t' || c == '\r' || c == '\n';
            if (!space)
                a.text += c;
            else if (!a.text.empty() && a.text.back() != ' ')
                a.text += ' ';
        }
        if (!a.text.empty() && a.text.back() == ' ') a.text.pop_back();
        if (const std::string problem = alarm_rules::textProblem(a.text); !problem.empty()) refuse(problem);
        m.alarms.push_back(std::move(a));
    }

    // <on_overrun> and <overrun_limit>: the per-module watchdog (docs/faults.md).
    void overrunWatchdog(pugi::xml_node action, pugi::xml_node limit, ModuleSpec &m) {
        if (limit && !action) failField(limit, m.name, "overrun_limit", "needs an <on_overrun> saying what to do");
        if (!action) return;
        if (m.operation != OperationType::Periodic)
            failField(action, m.name, "on_overrun", "only periodic modules have an overrun watchdog");
        const bool thread = m.type == ModuleType::Thread;
        const std::string a = leafText(action, m.name);
        static const std::map<std::string, OverrunAction> known = {{"warn", OverrunAction::Warn},
                                                                   {"skip", OverrunAction::Skip},
                                                                   {"disable", OverrunAction::Disable},
                                                                   {"stop", OverrunAction::Stop},
                                                                   {"restart", OverrunAction::Restart}};
        auto it = known.find(a);
        const bool allowed =
            it != known.end() && (thread ? it->second != OverrunAction::Restart
                                         : it->second != OverrunAction::Skip && it->second != OverrunAction::Disable);
        if (!allowed)
            failField(action, m.name, "on_overrun",
                      "unknown value '" + a + "'; expected " +
                          (thread ? "warn, skip, disable or stop" : "warn, restart or stop") + " for a " +
                          toString(m.type) + " module");
        m.on_overrun = it->second;
        m.overrun_limit_ns = m.deadline_ns ? m.deadline_ns : m.period_ns;
        if (limit) m.overrun_limit_ns = integer(limit, m.name, leafText(limit, m.name), 1, " number of nanoseconds");
    }

    void properties(pugi::xml_node props, ModuleSpec &m) {
        noAttributes(props);
        std::set<std::string> seen;
        for (pugi::xml_node v : props.children()) {
            if (skippable(v)) continue;
            if (std::string_view(v.name()) != "value")
                fail(v, "module '" + m.name + "': unknown tag <" + std::string(v.name()) +
                            "> in <property>; expected <value name=\"...\">");
            std::string name;
            bool has_name = false;
            for (pugi::xml_attribute a : v.attributes()) {
                if (std::string_view(a.name()) != "name")
                    fail(v, "module '" + m.name + "': unknown attribute '" + a.name() +
                                "' on <value>; expected name=\"...\"");
                if (has_name) fail(v, "module '" + m.name + "': name=\"...\" appears twice on one <value>");
                name = unescape(v, a.value());
                has_name = true;
            }
            if (!has_name || name.empty()) fail(v, "module '" + m.name + "': <value> without a name=\"...\"");
            if (!seen.insert(name).second) fail(v, "module '" + m.name + "': property '" + name + "' is set twice");
            pugi::xml_node element;
            const std::string raw = mixedText(v, element);
            if (element) fail(element, "module '" + m.name + "': property '" + name + "' must be plain text");
            if (raw.find('\0') != std::string::npos)
                fail(v, "module '" + m.name + "': property '" + name + "' contains a NUL");
            std::string value(trim(raw));
            // A process's own properties are checked now, so that `check` refuses what the start would.
            if (m.type == ModuleType::Process)
                if (Status st = applyProcessProperty(m.process, name, value); !st)
                    fail(v, "module '" + m.name + "': " + st.error().message);
            m.properties.emplace_back(std::move(name), std::move(value));
        }
    }

    void checkName(pugi::xml_node at, const std::string &name, const char *what = "module") const {
        if (name.empty()) fail(at, std::string(what) + " name is empty");
        if (name.size() > kMaxNameLength)
            fail(at, std::string(what) + " name '" + name + "' is longer than " + std::to_string(kMaxNameLength) +
                         " characters");
        for (char c : name)
            if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'))
                fail(at, std::string(what) + " name '" + name + "' may only hold letters, digits, '_', '-' and '.'" +
                             (std::string_view(what) == "module" ? "; set <name> to choose one" : ""));
    }

    // ---- <executor> -------------------------------------------------------------------------
    ExecutorSpec executor(pugi::xml_node node) {
        noAttributes(node);
        ExecutorSpec e;
        e.line = lineOf(node);
        owner_kind_ = "executor";
        const std::string label = std::string(trim(node.child("name").child_value()));
        module_ = label;
        std::set<std::string> seen;
        for (pugi::xml_node child : node.children()) {
            if (skippable(child)) continue;
            std::string tag = child.name();
            if (!seen.insert(tag).second) fail(child, "<" + tag + "> appears twice in one <executor>");
            if (tag == "name")
                e.name = leafText(child, "");
            else if (tag == "rtpriority") {
                std::string text = leafText(child, label);
                e.rt_priority = static_cast<int>(integer(child, label, text, 1, " from 1 to 99"));
                if (e.rt_priority > 99) failField(child, label, "rtpriority", "'" + text + "' must be from 1 to 99");
            } else if (tag == "cpu") {
                std::string text = leafText(child, label);
                e.cpu = static_cast<int>(integer(child, label, text, 0, " (a CPU number)"));
                if (e.cpu > 4095) failField(child, label, "cpu", "'" + text + "' must be a CPU number below 4096");
            } else
                fail(child, "unknown tag <" + tag + "> in <executor>; expected name, rtpriority or cpu");
        }
        owner_kind_ = "module";
        if (e.name.empty()) fail(node, "<executor> without a <name>");
        checkName(node, e.name, "executor");
        if (e.name == kMainExecutor) fail(node, "executor name 'main' is reserved for the default dispatcher");
        return e;
    }

    // ---- whole-set checks -------------------------------------------------------------------
    void crossCheck(const SetSpec &set) const {
        std::map<std::string, const ModuleSpec *> by_name;
        for (const ModuleSpec &m : set.modules) {
            auto [it, fresh] = by_name.emplace(m.name, &m);
            if (!fresh)
                failOwner(m.line, m.name,
                          "module '" + m.name + "': duplicate name (also the module at line " +
                              std::to_string(it->second->line) + "); set <name> on one of them");
        }
        std::set<std::string> executors;
        for (const ExecutorSpec &e : set.executors)
            if (!executors.insert(e.name).second)
                failOwner(e.line, e.name, "executor '" + e.name + "' is defined twice");
        for (std::size_t i = 0; i < executor_refs_.size(); ++i) {
            const auto &[name, node] = executor_refs_[i];
            if (name != kMainExecutor && !executors.count(name))
                failField(node, executor_ref_module_[i], "executor",
                          "no <executor> named '" + name + "' is defined at the root");
        }
    }

    std::string_view text_;
    std::string owner_kind_ = "module";  // what failField names: a module or an executor
    std::string module_;                 // the module or executor being read, once its name is known
    std::string shown_;                  // the path as the user gave it, for messages
    std::filesystem::path path_;         // absolute, anchors relative filenames
    std::vector<std::pair<std::string, pugi::xml_node>> executor_refs_;
    std::vector<std::string> executor_ref_module_;
};

}  // namespace

Result<SetSpec> parseModuleXmlText(std::string_view text, const std::filesystem::path &xml_path) {
    if (text.size() > kMaxXmlBytes)
        return fileError(xml_path.string(),
                         "larger than " + std::to_string(kMaxXmlBytes >> 20) + " MiB; not a module.xml");
    try {
        return Parser(text, xml_path).run();
    } catch (const ParseFailure &f) {
        return Error{f.message, protocol::kRefused, f.place};
    }
}

Result<SetSpec> parseModuleXml(const std::filesystem::path &xml_path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(xml_path, ec))
        return fileError(xml_path.string(), "no such file (the set's module.xml)");
    auto size = std::filesystem::file_size(xml_path, ec);
    if (ec) return fileError(xml_path.string(), ec.message());
    if (size > kMaxXmlBytes)
        return fileError(xml_path.string(),
                         "larger than " + std::to_string(kMaxXmlBytes >> 20) + " MiB; not a module.xml");
    std::ifstream in(xml_path, std::ios::binary);
    if (!in) return fileError(xml_path.string(), "cannot be read");
    std::ostringstream buffer;
    buffer << in.rdbuf();
    std::string text = buffer.str();
    return parseModuleXmlText(text, xml_path);
}

}  // namespace irp::config
