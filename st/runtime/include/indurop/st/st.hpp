// st.hpp -- the runtime that C++ generated from IEC 61131-3 Structured Text compiles against
// (namespace irp::st, header-only; docs/st-runtime.md is its reference).  The generated code
// includes this one header:
//   types.hpp           BOOL, SINT .. ULINT, BYTE .. LWORD, REAL, LREAL, TIME .. DT as C++ types
//   fault.hpp           Place, RuntimeFault, fault(), index(), range()
//   arith.hpp           ADD SUB MUL NEG DIV MOD (wrapping, faulting), EQ NE LT LE GT GE
//   bits.hpp            AND OR XOR NOT SHL SHR ROL ROR, getBit / setBit
//   time.hpp            ADD_TIME, SUB_DT_DT, MUL_TIME, DIV_TIME, CONCAT_DATE_TOD, ...
//   convert.hpp         <FROM>_TO_<TO> of the elementary types, TRUNC, TRUNC_<INT type>
//   numeric.hpp         ABS SQRT LN LOG EXP SIN COS TAN ASIN ACOS ATAN ATAN2 EXPT
//   select.hpp          SEL MAX MIN LIMIT MUX MOVE
//   string.hpp          String<N>, LEN LEFT RIGHT MID CONCAT INSERT DELETE REPLACE FIND
//   string_convert.hpp  <TYPE>_TO_STRING, STRING_TO_<TYPE>
//   loop.hpp            loopCheck(): the endless-loop guard on loop back-edges
//   image.hpp           copyIn / writeBack of shared variables, cycleTime()
//   kept.hpp            the kept image: a table of the struct and array variables a run copies
//   in_place.hpp        a PROGRAM run in place in the segment: inPlace, openGroup / closeGroup
#pragma once

#include <indurop/st/arith.hpp>
#include <indurop/st/bits.hpp>
#include <indurop/st/convert.hpp>
#include <indurop/st/fault.hpp>
#include <indurop/st/image.hpp>
#include <indurop/st/in_place.hpp>
#include <indurop/st/kept.hpp>
#include <indurop/st/loop.hpp>
#include <indurop/st/numeric.hpp>
#include <indurop/st/select.hpp>
#include <indurop/st/string.hpp>
#include <indurop/st/string_convert.hpp>
#include <indurop/st/time.hpp>
#include <indurop/st/types.hpp>
