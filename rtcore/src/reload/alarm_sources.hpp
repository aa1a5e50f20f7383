// alarm_sources.hpp -- which source of the alarm segment each module of a generation raises its
// alarms on (docs/alarms.md, "Sources and swaps").  Sources go by module name:
//
//   assign  (realize, before anything loads) a module whose name the running generation has
//           keeps that module's source, kept or loaded anew (a new instance adds its module.xml
//           declarations to the source's until the swap); a new name claims the lowest source
//           neither generation uses: a new generation number, its module.xml declarations,
//           everything else zero.  The first set: module i takes source 1 + i;
//   settle  (after the swap) each source declares exactly what its module now declares
//           (module.xml's, and irp::declareAlarm's of a thread module); the sources of the
//           names the new generation dropped are freed (all zero);
//   undo    (a prepare that failed) the sources it claimed are freed, the others declare again
//           what the running generation's modules declare.
//
// All on irpd's main thread; the modules' threads write the same sources meanwhile (their bitmaps
// and counters, never their name, generation or declared ids, which are irpd's).
#pragma once

#include "alarms/alarm_segment.hpp"
#include <indurop/result.hpp>
#include "reload/generation.hpp"

namespace irp::reload {

// On failure (no free source) undoAlarmSources takes back what it did.
Status assignAlarmSources(alarms::AlarmSegment &segment, Generation &next, const Generation *running);
void settleAlarmSources(alarms::AlarmSegment &segment, const Generation &next, const Generation &old);
void undoAlarmSources(alarms::AlarmSegment &segment, Generation &partial, const Generation *running);

// What a module declares: module.xml's <alarm>s and, for a loaded thread module, irp::declareAlarm's.
alarms::Bitmap declaredIds(const config::ModuleSpec &m, const Member &member);

}  // namespace irp::reload
