// describe.hpp -- how irpd describes what it lays out in shared memory, field by field, so that
// readers in other languages take every offset from irpd (`irpd --print-shm-layout`,
// docs/shared-memory.md) instead of writing one down.
//
// A struct is described by a table of fields built with IRP_SHM_FIELD: the compiler supplies each
// field's offset, size and type, the table supplies its name and meaning.  IRP_SHM_DESCRIBES
// checks at compile time that the table covers every byte of the struct, in order, so a member
// added to a struct (anywhere but in the tail padding of an over-aligned struct) stops the build
// until it is described.  Nothing here runs on an RT thread: the tables are constants that only
// --print-shm-layout reads.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <pthread.h>
#include <span>
#include <string_view>
#include <type_traits>

namespace irp::shm {

// How a reader sees a field's element type: "u8" … "u64", "i8" … "i64", "f32", "f64", "char"
// (text, NUL-terminated unless said otherwise), "pthread_mutex_t" (opaque to readers), or the name
// of another described struct.  Unspecialised: the build fails naming the type to describe.
template <class T>
struct TypeName;
template <class T>
struct TypeName<std::atomic<T>> : TypeName<T> {};  // read as the plain value
template <class T>
requires std::is_enum_v<T>
struct TypeName<T> : TypeName<std::underlying_type_t<T>> {
};  // its values are listed as an Enum
template <>
struct TypeName<uint8_t> {
    static constexpr std::string_view value = "u8";
};
template <>
struct TypeName<uint16_t> {
    static constexpr std::string_view value = "u16";
};
template <>
struct TypeName<uint32_t> {
    static constexpr std::string_view value = "u32";
};
template <>
struct TypeName<uint64_t> {
    static constexpr std::string_view value = "u64";
};
template <>
struct TypeName<int8_t> {
    static constexpr std::string_view value = "i8";
};
template <>
struct TypeName<int16_t> {
    static constexpr std::string_view value = "i16";
};
template <>
struct TypeName<int32_t> {
    static constexpr std::string_view value = "i32";
};
template <>
struct TypeName<int64_t> {
    static constexpr std::string_view value = "i64";
};
template <>
struct TypeName<float> {
    static constexpr std::string_view value = "f32";
};
template <>
struct TypeName<double> {
    static constexpr std::string_view value = "f64";
};
template <>
struct TypeName<char> {
    static constexpr std::string_view value = "char";
};
template <>
struct TypeName<pthread_mutex_t> {
    static constexpr std::string_view value = "pthread_mutex_t";
};

struct Field {
    std::string_view name;
    std::size_t offset;     // from the start of the struct
    std::size_t size;       // bytes of the whole field (all elements of an array)
    std::string_view type;  // the element type (TypeName)
    std::size_t count;      // elements of an array; 0: not an array
    std::string_view meaning;
};

template <class Member>
constexpr Field field(std::string_view name, std::size_t offset, std::string_view meaning) {
    using Element = std::remove_all_extents_t<Member>;
    return {name,
            offset,
            sizeof(Member),
            TypeName<Element>::value,
            std::is_array_v<Member> ? sizeof(Member) / sizeof(Element) : 0,
            meaning};
}

// The name readers see for described struct S (inside namespace irp::shm):
// IRP_SHM_TYPE_NAME(stats::Header, "stats_header");
#define IRP_SHM_TYPE_NAME(S, name)                                                                                     \
    template <>                                                                                                        \
    struct TypeName<S> {                                                                                               \
        static constexpr std::string_view value = name;                                                                \
    }

// One field of struct S: IRP_SHM_FIELD(indurop_trace_header, head, "seq of the newest row").
#define IRP_SHM_FIELD(S, member, meaning)                                                                              \
    ::irp::shm::field<decltype(S::member)>(#member, __builtin_offsetof(S, member), meaning)

// Where a field table stops describing a struct of `size` bytes aligned to `align`: the offset of
// the first byte no field covers (fields out of order count as a gap), or `size` when the table
// covers every byte but the tail padding that alignment adds (less than `align` bytes).
constexpr std::size_t firstUndescribed(std::span<const Field> fields, std::size_t size, std::size_t align) {
    std::size_t at = 0;
    for (const Field &f : fields) {
        if (f.offset != at) return at;
        at += f.size;
    }
    if (at > size || size - at >= align) return at;
    return size;
}

template <class S>
constexpr bool describesEveryByte(std::span<const Field> fields) {
    return firstUndescribed(fields, sizeof(S), alignof(S)) == sizeof(S);
}

// Stops the build when `fields` leaves a byte of S undescribed: a member added, moved or resized.
#define IRP_SHM_DESCRIBES(S, fields)                                                                                   \
    static_assert(::irp::shm::describesEveryByte<S>(fields),                                                           \
                  #S ": a member is not described (or the table is out of order); add it to " #fields                  \
                     " with its meaning, then regenerate with `ninja -C build shm-layout`")

// A struct as readers see it.
struct Struct {
    std::string_view name;
    std::size_t size;
    std::size_t align;
    std::string_view meaning;
    std::span<const Field> fields;  // in offset order, covering every byte but tail padding
};

template <class S>
constexpr Struct describe(std::string_view meaning, std::span<const Field> fields) {
    return {TypeName<S>::value, sizeof(S), alignof(S), meaning, fields};
}

// A named number readers need: a limit, a sentinel, an enum's value.
struct Constant {
    std::string_view name;
    uint64_t value;
    std::string_view meaning;
};

struct Enum {
    std::string_view name;
    std::string_view meaning;
    std::span<const Constant> values;
};

// One segment irpd creates in /dev/shm.
struct Segment {
    std::string_view name;     // "variables", "stats", "trace", "control", "alarms"
    std::string_view shm;      // "/indurop.<instance>.vars"
    std::string_view meaning;  // what it is for and how its parts follow one another
    uint64_t magic;            // the u64 at offset 0
    uint32_t version;          // the u32 at offset 8
    std::string_view header;   // the struct at offset 0 (its header_size field, at offset 12, is its size)
    std::span<const Struct> structs;
    std::span<const Constant> constants;
    std::span<const Enum> enums;
};

// The segments, each described in its own file of this folder.
const Segment &variablesSegment();
const Segment &statsSegment();
const Segment &traceSegment();
const Segment &controlSegment();
const Segment &alarmsSegment();

}  // namespace irp::shm
