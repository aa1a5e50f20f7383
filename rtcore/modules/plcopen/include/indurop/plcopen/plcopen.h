// plcopen.h -- the PLC function-block library of indurop (static library indurop_plcopen): the
// IEC 61131-3 basics (iec.h) and the PLCopen-style motion blocks on an axis group (motion.h,
// axis_group.h).  docs/plc.md describes every block with its timing.
#pragma once

#include <indurop/plcopen/axis_group.h>
#include <indurop/plcopen/iec.h>
#include <indurop/plcopen/motion.h>
