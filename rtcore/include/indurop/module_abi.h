/* module_abi.h -- the C table that crosses the dlopen boundary between irpd and a thread module.
 *
 * A thread module (.so) exports one function, INDUROP_MODULE_DESCRIPTOR_SYMBOL, returning a
 * pointer to a static indurop_module_v1.  INDUROP_MODULE(...) in <indurop/indurop.h> writes it
 * for you; a module may instead export the plain extern "C" entry points of the paper's Figure 12
 * (initialize, start, run, stop, condition), which irpd wraps into the same table.
 *
 * Rules for the table: plain C types only, never reordered; new hooks go at the end and bump
 * INDUROP_MODULE_ABI_VERSION; irpd reads at most struct_size bytes of it.
 */
#ifndef INDUROP_MODULE_ABI_H
#define INDUROP_MODULE_ABI_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define INDUROP_MODULE_ABI_VERSION 1u
#define INDUROP_MODULE_DESCRIPTOR_SYMBOL "indurop_module_v1_descriptor"

/* One <value name="...">...</value> of a module's <property> block, as written in module.xml. */
typedef struct indurop_property_entry {
    const char *name;
    const char *value;
} indurop_property_entry;

typedef struct indurop_property_list {
    const indurop_property_entry *entries;
    size_t count;
} indurop_property_list;

/* Hooks return 0 on success; on failure they write a NUL-terminated reason into err (at most
 * err_len bytes, including the NUL) and return non-zero.  Every hook but run may be NULL. */
typedef struct indurop_module_v1 {
    uint32_t abi_version; /* INDUROP_MODULE_ABI_VERSION the module was built with */
    uint32_t struct_size; /* sizeof(indurop_module_v1) in the module's build */

    const char *name; /* display metadata; the scheduling name comes from module.xml */
    const char *description;
    const char *author;
    const char *license;

    int (*initialize)(const indurop_property_list *properties, char *err, size_t err_len);
    int (*start)(char *err, size_t err_len);
    void (*run)(void); /* called every period on the RT thread: see indurop.h for the rules */
    void (*stop)(void);
    int (*condition)(void); /* sporadic modules: non-zero when the event occurred */
} indurop_module_v1;

typedef const indurop_module_v1 *(*indurop_module_descriptor_fn)(void);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* INDUROP_MODULE_ABI_H */
