# test_errors.py -- one named case per kind of error check.py and parse.py report: the file, line,
# column, code and the wording that names the fix, as `stc check` prints them.

from __future__ import annotations

import pytest
from st_helpers import errors_of, program


@pytest.mark.parametrize(
    ("text", "where", "message"),
    [
        pytest.param(
            program("b : BOOL;", "b := 2;"),
            (5, 6, "type"),
            "cannot assign DINT to BOOL; use DINT_TO_BOOL(...)",
            id="type_integer_other_than_1_or_0_to_bool",
        ),
        pytest.param(
            program("x : INT;", "x := 1\nx := 2;"),
            (5, 7, "syntax"),
            "expected ';' after the assignment",
            id="syntax_missing_semicolon",
        ),
        pytest.param(
            program("x : INT;", "IF x > 1 THEN x := 1;"),
            (6, 1, "syntax"),
            "expected END_IF to close the IF of line 5, found 'END_PROGRAM'",
            id="syntax_unclosed_if",
        ),
        pytest.param(
            program("then : INT;", "then := 1;"),
            (3, 1, "syntax"),
            "expected 'CONSTANT', 'END_VAR', 'NON_RETAIN', 'PERSISTENT', 'RETAIN' or a name, found 'THEN'; 'then' is a keyword: choose another name",
            id="syntax_keyword_as_name",
        ),
        pytest.param(
            program("x : INT;", "x := 1 ? 2;"),
            (5, 8, "syntax"),
            "unexpected character '?'; it is not part of Structured Text here",
            id="syntax_unexpected_character",
        ),
        pytest.param(
            program("s : STRING;", "s := 'abc;"),
            (5, 6, "syntax"),
            "the string is not closed on its line; end it with '",
            id="syntax_unclosed_string",
        ),
        pytest.param(
            program("x : INT;", "(* never closed\nx := 1;"),
            (5, 1, "syntax"),
            "the comment '(*' is never closed; close it with '*)'",
            id="syntax_unclosed_comment",
        ),
        pytest.param(
            program("t : TIME;", "t := T#5x;"),
            (5, 6, "literal"),
            "'T#5x' is not a duration; write e.g. T#1s200ms (units d, h, m, s, ms, us, ns)",
            id="literal_bad_duration",
        ),
        pytest.param(
            program("x : SINT;", "x := SINT#300;"),
            (5, 6, "range"),
            'SINT#300 does not fit SINT (-128..127); use a wider type',
            id="literal_out_of_range",
        ),
        pytest.param(
            program("x : INT; b : BOOL;", "b := x;"),
            (5, 6, "type"),
            'cannot assign INT to BOOL; use INT_TO_BOOL(...)',
            id="assign_int_to_bool",
        ),
        pytest.param(
            program("x : DINT; i : INT;", "i := x;"),
            (5, 6, "type"),
            'cannot assign DINT to INT (it may lose data); use DINT_TO_INT(...)',
            id="assign_narrowing",
        ),
        pytest.param(
            program("r : REAL; i : INT;", "i := r;"),
            (5, 6, "type"),
            'cannot assign REAL to INT (it may lose data); use REAL_TO_INT(...)',
            id="assign_real_to_int",
        ),
        pytest.param(
            program("w : WORD; i : UINT;", "i := w;"),
            (5, 6, "type"),
            'cannot assign WORD to UINT; use WORD_TO_UINT(...)',
            id="bits_to_int",
        ),
        pytest.param(
            program("x : SINT;", "x := 200;"),
            (5, 6, "range"),
            '200 does not fit SINT (-128..127); use a wider type',
            id="literal_does_not_fit",
        ),
        pytest.param(
            "PROGRAM Main\nVAR CONSTANT x : INT := 3; END_VAR\n  x := 1;\nEND_PROGRAM\n",
            (3, 3, "constant"),
            "'x' is CONSTANT and cannot be assigned; remove CONSTANT or use another variable",
            id="constant_assigned",
        ),
        pytest.param(
            program("t : TON;", "t.IN := TRUE;"),
            (5, 1, "access"),
            "'t.IN' is an input of TON; set it through the call: t(IN := ...)",
            id="input_assigned_from_outside",
        ),
        pytest.param(
            program("t : TON;", "t.Q := TRUE;"),
            (5, 1, "access"),
            "'t.Q' is an output of TON; only TON writes it",
            id="output_assigned_from_outside",
        ),
        pytest.param(
            program("t : TON; b : BOOL;", "b := t.RUNNING;"),
            (5, 6, "access"),
            "'RUNNING' is internal to TON (VAR); declare it VAR_OUTPUT to read it from outside",
            id="internal_read_from_outside",
        ),
        pytest.param(
            program("t : TON;", "t(IN := TRUE, PTT := T#1s);"),
            (5, 15, "parameter"),
            "TON has no parameter 'PTT'; did you mean 'PT'?",
            id="unknown_parameter",
        ),
        pytest.param(
            program("t : TON;", "t(Q := TRUE);"),
            (5, 3, "direction"),
            "'Q' is an output of TON; read it with Q => <variable>",
            id="wrong_direction_output",
        ),
        pytest.param(
            program("t : TON; b : BOOL;", "t(IN => b);"),
            (5, 3, "direction"),
            "'IN' is an input of TON; pass it with IN := <value>",
            id="wrong_direction_input",
        ),
        pytest.param(
            program("t : TON;", "t(IN := TRUE, PT := 5);"),
            (5, 21, "type"),
            'the parameter PT is TIME, not DINT; use DINT_TO_TIME(...)',
            id="parameter_type",
        ),
        pytest.param(
            program("t : TON; b : BOOL;", "b := t(IN := TRUE);"),
            (5, 6, "call"),
            'an FB call is a statement of its own; call t(...); then read its outputs (t.<output>)',
            id="fb_call_in_expression",
        ),
        pytest.param(
            "FUNCTION F VAR_INPUT a : INT; END_VAR ; END_FUNCTION\n" + program("x : INT;", "x := F(1);"),
            (6, 6, "call"),
            'FUNCTION F returns no value; call it as a statement or give it a result type',
            id="function_without_result",
        ),
        pytest.param(
            "FUNCTION Fact : DINT\nVAR_INPUT n : DINT; END_VAR\n  Fact := n * Fact(n - 1);\nEND_FUNCTION\n",
            (3, 15, "recursion"),
            'recursive call chain Fact -> Fact; IEC 61131-3 forbids recursion: use a loop',
            id="recursion",
        ),
        pytest.param(
            "FUNCTION A : INT\nVAR_INPUT n : INT; END_VAR\n  A := B(n);\nEND_FUNCTION\nFUNCTION B : INT\nVAR_INPUT n : INT; END_VAR\n  B := A(n);\nEND_FUNCTION\n",
            (7, 8, "recursion"),
            'recursive call chain A -> B -> A; IEC 61131-3 forbids recursion: use a loop',
            id="recursion_chain",
        ),
        pytest.param(
            "FUNCTION_BLOCK Loop\nVAR inner : Loop; END_VAR\nEND_FUNCTION_BLOCK\n",
            (2, 5, "recursion"),
            'recursive call chain Loop -> Loop; IEC 61131-3 forbids recursion: use a loop',
            id="fb_contains_itself",
        ),
        pytest.param(
            program("x : INT; X : DINT;", ""),
            (3, 10, "duplicate"),
            "'X' is declared twice (first at line 3); rename one of them",
            id="duplicate_variable",
        ),
        pytest.param(
            "FUNCTION_BLOCK Pump\nEND_FUNCTION_BLOCK\nFUNCTION_BLOCK PUMP\nEND_FUNCTION_BLOCK\n",
            (3, 1, "duplicate"),
            "'PUMP' is declared twice (first at line 1); rename one of them",
            id="duplicate_pou",
        ),
        pytest.param(
            program("counter : INT;", "countr := 1;"),
            (5, 1, "undeclared"),
            "'countr' is not declared; did you mean 'counter'?",
            id="undeclared_with_suggestion",
        ),
        pytest.param(
            program("x : DIN;", ""),
            (3, 5, "undeclared"),
            "unknown type 'DIN'; did you mean 'DINT'?",
            id="undeclared_type",
        ),
        pytest.param(
            program("x : INT;", "CASE x OF\n1..5: x := 0;\n3: x := 1;\nEND_CASE;"),
            (7, 1, "case-overlap"),
            'this CASE label overlaps the one on line 6 (1..5); each value may have one branch',
            id="case_overlap",
        ),
        pytest.param(
            program("x : INT; y : INT;", "CASE x OF\ny: x := 0;\nEND_CASE;"),
            (6, 1, "constant"),
            'a CASE label must be a constant (a literal, a CONSTANT or an enumeration value)',
            id="case_label_not_constant",
        ),
        pytest.param(
            program("x : INT;", "EXIT;"),
            (5, 1, "loop"),
            'EXIT outside a loop; it may stand only inside FOR, WHILE or REPEAT',
            id="exit_outside_loop",
        ),
        pytest.param(
            program("x : INT;", "IF x > 0 THEN CONTINUE; END_IF;"),
            (5, 15, "loop"),
            'CONTINUE outside a loop; it may stand only inside FOR, WHILE or REPEAT',
            id="continue_outside_loop",
        ),
        pytest.param(
            program("new : INT;", "new := 1;"),
            (3, 1, "name"),
            "'new' is a C++ keyword and cannot be used as a name; rename the variable",
            id="cpp_keyword_name",
        ),
        pytest.param(
            program("std : INT;", ""),
            (3, 1, "name"),
            "'std' is reserved (a macro or namespace the generated header relies on); rename the variable",
            id="reserved_name",
        ),
        pytest.param(
            program("x : INT;", "WHILE x DO x := x - 1; END_WHILE;"),
            (5, 7, "type"),
            'the WHILE condition is INT, not BOOL; compare it, e.g. `<> 0`',
            id="condition_not_bool",
        ),
        pytest.param(
            program("n : INT; a : ARRAY[1..n] OF INT;", ""),
            (3, 23, "constant"),
            'an array bound must be a constant integer expression (literals, CONSTANTs)',
            id="array_bound_not_constant",
        ),
        pytest.param(
            program("a : ARRAY[1..3] OF INT;", "a[4] := 1;"),
            (5, 3, "range"),
            "the index 4 is outside the array's range 1..3",
            id="index_out_of_range",
        ),
        pytest.param(
            program("b : BYTE; q : BOOL;", "q := b.8;"),
            (5, 6, "range"),
            'BYTE has bits 0..7, not 8',
            id="bit_out_of_range",
        ),
        pytest.param(
            program("s : STRING[0];", ""),
            (3, 12, "range"),
            'a STRING length is 1..65535, not 0',
            id="string_length",
        ),
        pytest.param(
            program("x : INT;", "x := x / 0;"),
            (5, 10, "division"),
            'division by zero; divide by something other than 0',
            id="division_by_constant_zero",
        ),
        pytest.param(
            program("x : INT;", "x := LIMIT(1, x);"),
            (5, 6, "call"),
            'LIMIT takes 3 arguments (MN, IN, MX), not 2',
            id="std_function_arguments",
        ),
        pytest.param(
            program("x : INT;", "x := SQRT(x);"),
            (5, 11, "type"),
            "SQRT's IN is ANY_REAL, not INT; use INT_TO_LREAL(...)",
            id="generic_family",
        ),
        pytest.param(
            program("x : INT; b : BOOL;", "b := x = TRUE;"),
            (5, 6, "type"),
            'cannot compare INT with BOOL; convert one of them, e.g. BOOL_TO_INT(...)',
            id="compare_mismatch",
        ),
        pytest.param(
            program("x : INT;", "TON(IN := TRUE);"),
            (5, 1, "call"),
            'TON is a FUNCTION_BLOCK type; declare an instance (`t : TON;`) and call it: t(...)',
            id="call_fb_type",
        ),
        pytest.param(
            "PROGRAM Main\nVAR_EXTERNAL g : INT; END_VAR\nEND_PROGRAM\n",
            (2, 14, "undeclared"),
            "no VAR_GLOBAL 'g' for this VAR_EXTERNAL; declare it in a VAR_GLOBAL list",
            id="var_external_without_global",
        ),
        pytest.param(
            "TYPE A : (On1, Off1); B : (On1, X1); END_TYPE\n" + program("a : A;", "a := On1;"),
            (6, 6, "ambiguous"),
            "'On1' is a value of several enumerations; write A#On1 or B#On1",
            id="enum_ambiguous",
        ),
        pytest.param(
            "PROGRAM Main VAR x : INT; END_VAR x := 1; END_PROGRAM\nCONFIGURATION C\nRESOURCE R ON PLC\nTASK T1 (INTERVAL := T#10ms, PRIORITY := 1);\nPROGRAM M1 WITH T2 : Main;\nEND_RESOURCE\nEND_CONFIGURATION\n",
            (5, 1, "undeclared"),
            "no TASK 'T2' in RESOURCE R",
            id="task_unknown",
        ),
        pytest.param(
            program("x : INT;", "x := x^;"),
            (5, 7, "unsupported"),
            'pointers (^) are not supported; use VAR_IN_OUT to pass a variable by reference',
            id="pointer",
        ),
        pytest.param(
            program("x AT %IX0.0 : BOOL;", ""),
            (3, 1, "binding"),
            'direct addresses such as %IX0.0 are not supported; bind to a shared variable: AT %<namespace>.<variable>',
            id="direct_address",
        ),
        pytest.param(
            "FUNCTION_BLOCK Inc VAR_IN_OUT v : INT; END_VAR v := v + 1; END_FUNCTION_BLOCK\n"
            + program("i : Inc;", "i(v := 3);"),
            (6, 3, "parameter"),
            "the VAR_IN_OUT 'v' needs a variable, not an expression",
            id="in_out_needs_variable",
        ),
        pytest.param(
            "TYPE Color : (Red, Green); END_TYPE\n" + program("c : Color;", "c := 1;"),
            (6, 6, "type"),
            "cannot assign DINT to the enumeration Color; give one of its values, e.g. Color#Red",
            id="enum_from_integer",
        ),
        pytest.param(
            program("x : INT;", "x = 1;"),
            (5, 3, "syntax"),
            "expected ':=' to assign (or to pass a parameter), found '='; '=' compares",
            id="syntax_equals_for_assignment",
        ),
        pytest.param(
            program("x : INT;", "IF x > 1 x := 2; END_IF;"),
            (5, 10, "syntax"),
            "expected 'THEN' or an operator, found the name 'x'",
            id="syntax_missing_then",
        ),
        pytest.param(
            program("x : INT;", "x := (1 + 2;"),
            (5, 12, "syntax"),
            "expected ')', found ';'",
            id="syntax_unclosed_parenthesis",
        ),
        pytest.param(
            program("x : INT;", "WHILE x < 3 DO x := x + 1; END_FOR;"),
            (5, 28, "syntax"),
            "expected END_WHILE to close the WHILE of line 5, found 'END_FOR'",
            id="syntax_wrong_end",
        ),
        pytest.param(
            program("x : INT;", "x := 1;")
            + "FUNCTION Max : INT\nVAR_INPUT a, b : INT; END_VAR\n  Max := a;\nEND_FUNCTION\n",
            (7, 1, "reserved"),
            "'Max' is a standard function, and IEC 61131-3 reserves its name; rename the FUNCTION "
            "(e.g. 'MyMax') and its calls",
            id="reserved_standard_function",
        ),
        pytest.param(
            "FUNCTION_BLOCK TON\nVAR_INPUT IN : BOOL; END_VAR\nEND_FUNCTION_BLOCK\n",
            (1, 1, "reserved"),
            "'TON' is a standard function block (st/lib/standard.st), and IEC 61131-3 reserves its name; "
            "rename the FUNCTION_BLOCK (e.g. 'MyTon') and its calls",
            id="reserved_standard_function_block",
        ),
        pytest.param(
            "FUNCTION int_to_real : REAL\nVAR_INPUT IN : INT; END_VAR\n  int_to_real := 1.0;\nEND_FUNCTION\n",
            (1, 1, "reserved"),
            "'int_to_real' is a standard function, and IEC 61131-3 reserves its name; rename the FUNCTION "
            "(e.g. 'MyInt_to_real') and its calls",
            id="reserved_conversion_function",
        ),
        pytest.param(
            program("x : INT;", "x := MAX(1, 70000);"),
            (5, 6, "range"),
            "70000 does not fit INT (-32768..32767); use a wider type",
            id="untyped_call_does_not_fit_its_target",
        ),
        pytest.param(
            program("x : UINT;", "x := LIMIT(-5, 3, 10);"),
            (5, 6, "range"),
            "-5 does not fit UINT (0..65535); use a wider type",
            id="untyped_call_negative_into_unsigned",
        ),
        pytest.param(
            program("x : INT;", "x := MAX(x, 70000);"),
            (5, 13, "range"),
            "70000 does not fit INT (-32768..32767), the type of the other arguments; use a wider type",
            id="literal_does_not_fit_the_other_argument",
        ),
        pytest.param(
            program("x : SINT;", "x := LIMIT(0, x, 300);"),
            (5, 18, "range"),
            "300 does not fit SINT (-128..127), the type of the other arguments; use a wider type",
            id="literal_does_not_fit_the_other_argument_of_limit",
        ),
        pytest.param(
            program("w : WORD;", "w := ABS(5);"),
            (5, 10, "type"),
            "ABS's IN is ANY_NUM, not WORD; convert its result, e.g. DINT_TO_WORD(ABS(...))",
            id="untyped_call_outside_its_family",
        ),
        pytest.param(
            program("x : INT;", "MUX(0, x, 70000);"),
            (5, 11, "range"),
            "70000 does not fit INT (-32768..32767), the type of the other arguments; use a wider type",
            id="call_statement_arguments_checked",
        ),
        pytest.param(
            "FUNCTION F : INT\nVAR_INPUT a : INT; END_VAR\n  F := a;\nEND_FUNCTION\n" + program("r : REAL;", "F(r);"),
            (9, 3, "type"),
            "the parameter a is INT, not REAL (it may lose data); use REAL_TO_INT(...)",
            id="function_statement_argument_checked",
        ),
    ],
)
def test_error(text: str, where: tuple[int, int, str], message: str):
    first = errors_of(text)[0]
    assert (first.file, first.line, first.col, first.code) == ("main.st", *where)
    assert first.message == message
    assert str(first) == f"main.st:{where[0]}:{where[1]}: error[{where[2]}]: {message}"
