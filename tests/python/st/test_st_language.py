# test_st_language.py -- every construct of docs/st.md's conformance table accepted by stc, with the type
# check.py gives it (and the tree parse.py builds) checked.

from __future__ import annotations

from pathlib import Path

import pytest
from st_helpers import compile_st, program
from stc_compiler import tree as t
from stc_compiler import types as ty
from stc_compiler.check_expr import GlbPath

DECLS = """
  b : BOOL; bt : BYTE; w : WORD; dw : DWORD; lw : LWORD;
  si : SINT; i : INT; di : DINT; li : LINT; usi : USINT; ui : UINT; udi : UDINT; uli : ULINT;
  r : REAL; lr : LREAL; tm : TIME; ltm : LTIME; d : DATE; tod1 : TIME_OF_DAY; dt1 : DATE_AND_TIME;
  s : STRING; s10 : STRING[10]; ws : WSTRING;
  arr : ARRAY[1..3] OF INT; m2 : ARRAY[0..1, -1..1] OF REAL; c : Color; p : Point; small : Small;
  ton1 : TON; ctu1 : CTU;
"""
TYPES = """
TYPE
  Color : (Red, Green := 5, Blue) := Green;
  Point : STRUCT x : REAL; y : REAL := 1.0; tag : STRING[8] := 'pt'; END_STRUCT;
  Small : INT (0..100);
END_TYPE
FUNCTION Twice : INT
VAR_INPUT IN : INT; END_VAR
  Twice := IN * 2;
END_FUNCTION
"""


def checked(body: str, decls: str = DECLS, extra: str = TYPES):
    prog = compile_st({"main.st": extra + program(decls, body)})
    return next(p for p in prog.pous.values() if p.name == "Main"), prog


def value_type(expr: str, target: str) -> str:
    """Assigns `expr` to the variable `target`; returns the type check.py gave the expression."""
    main, _ = checked(f"{target} := {expr};")
    stmt = main.body[0]
    assert isinstance(stmt, t.Assign)
    return str(stmt.value.type)


@pytest.mark.parametrize(
    ("expr", "target", "typ"),
    [
        # literals, every form
        ("INT#5", "i", "INT"),
        ("16#FF", "bt", "BYTE"),
        ("2#1010_0001", "bt", "BYTE"),
        ("8#17", "i", "INT"),
        ("1.5E3", "r", "REAL"),
        ("REAL#1.5", "r", "REAL"),
        ("T#1s200ms", "tm", "TIME"),
        ("TIME#-5ms", "tm", "TIME"),
        ("LTIME#1h2m", "ltm", "LTIME"),
        ("D#2024-01-02", "d", "DATE"),
        ("TOD#12:00:00.5", "tod1", "TOD"),
        ("DT#2024-01-02-12:00:00", "dt1", "DT"),
        ("'it$'s $N$24'", "s", "STRING[7]"),
        ('"wide"', "ws", "WSTRING[4]"),
        ("TRUE", "b", "BOOL"),
        ("Color#Red", "c", "Color"),
        ("Blue", "c", "Color"),
        # implicit widening conversions (IEC 61131-3 table 11)
        ("si", "i", "SINT"),
        ("i", "di", "INT"),
        ("i", "r", "INT"),
        ("r", "lr", "REAL"),
        ("si", "r", "SINT"),
        ("usi", "i", "USINT"),
        ("bt", "dw", "BYTE"),
        ("tm", "ltm", "TIME"),
        ("small", "i", "Small"),
        # operators with IEC precedence and their result types
        ("i + di", "di", "DINT"),
        ("i * 2 + 1", "i", "INT"),
        ("r ** 2.0", "r", "REAL"),
        ("-i", "i", "INT"),
        ("i MOD 3", "i", "INT"),
        ("i > 3 AND NOT b OR r < 1.0", "b", "BOOL"),
        ("w AND 16#FF00 XOR w", "w", "WORD"),
        ("b & b", "b", "BOOL"),
        ("tm + T#1s", "tm", "TIME"),
        ("tm * 2", "tm", "TIME"),
        ("dt1 - dt1", "tm", "TIME"),
        ("tod1 + T#1h", "tod1", "TOD"),
        ("s = 'x'", "b", "BOOL"),
        ("c = Red", "b", "BOOL"),
        # bit access, arrays, structs, FB outputs
        ("w.3", "b", "BOOL"),
        ("arr[2]", "i", "INT"),
        ("m2[1, -1]", "r", "REAL"),
        ("p.x", "r", "REAL"),
        ("ton1.Q", "b", "BOOL"),
        ("ctu1.CV", "i", "INT"),
        # standard functions, generic parameters resolved from the arguments
        ("INT_TO_BOOL(i)", "b", "BOOL"),
        ("REAL_TO_INT(r)", "i", "INT"),
        ("TIME_TO_DINT(tm)", "di", "DINT"),
        ("TRUNC(r)", "di", "DINT"),
        ("ABS(i)", "i", "INT"),
        ("SQRT(r)", "r", "REAL"),
        ("EXPT(lr, 2)", "lr", "LREAL"),
        ("SHL(w, 2)", "w", "WORD"),
        ("ROR(bt, 1)", "bt", "BYTE"),
        ("AND(w, 16#F)", "w", "WORD"),
        ("OR(b, b, b)", "b", "BOOL"),
        ("SEL(b, i, 3)", "i", "INT"),
        ("MAX(i, si, 0)", "i", "INT"),
        ("MIN(r, 1.0)", "r", "REAL"),
        ("LIMIT(0, i, 100)", "i", "INT"),
        ("MUX(i, di, di, di)", "di", "DINT"),
        ("GT(i, 3)", "b", "BOOL"),
        ("ADD(i, 1, 2)", "i", "INT"),
        ("MOVE(r)", "r", "REAL"),
        ("MOD(di, 7)", "di", "DINT"),
        ("LEN(s)", "i", "INT"),
        ("LEFT(s, 3)", "s", "STRING"),
        ("MID(s, 2, 3)", "s10", "STRING"),
        ("CONCAT(s, 'a', s10)", "s", "STRING"),
        ("INSERT(s, 'x', 2)", "s", "STRING"),
        ("DELETE(s, 1, 1)", "s", "STRING"),
        ("REPLACE(s, 'y', 1, 2)", "s", "STRING"),
        ("FIND(s, 'x')", "i", "INT"),
        ("TO_DINT(r)", "di", "DINT"),
        ("Twice(i)", "i", "INT"),
        ("Twice(IN := 3)", "i", "INT"),
        # untyped literals in a generic call take the type of the assignment's target or the other operand
        ("MAX(1, 2)", "i", "INT"),
        ("MIN(-100, 100)", "si", "SINT"),
        ("LIMIT(0, 70000, 100000)", "di", "DINT"),
        ("SEL(b, 0, 65535)", "ui", "UINT"),
        ("MUX(i, 1, 2, 3)", "si", "SINT"),
        ("ABS(-5)", "si", "SINT"),
        ("MAX(1.5, 2)", "r", "REAL"),
        ("SQRT(4)", "r", "REAL"),
        ("MAX(1, 2) + i", "i", "INT"),
        ("-MIN(1, 2)", "si", "SINT"),
        # a bare 1 or 0 is a boolean literal where a BOOL is expected (IEC 61131-3)
        ("1", "b", "BOOL"),
        ("0", "b", "BOOL"),
    ],
)
def test_expression_type(expr: str, target: str, typ: str):
    assert value_type(expr, target) == typ


def test_keywords_and_names_are_case_insensitive_and_keep_their_spelling():
    main, _ = checked("if Counter > 1 then COUNTER := counter + 1; end_if;", "Counter : DINT;")
    stmt = main.body[0]
    assert isinstance(stmt, t.If)
    cond, body = stmt.branches[0]
    assert cond.left.name == "Counter" and body[0].target.name == "COUNTER"
    assert body[0].target.decl is cond.left.decl  # one declaration, found by either spelling


def test_every_statement_form():
    body = """
    i := 1;
    IF i = 1 THEN i := 2; ELSIF i = 2 THEN i := 3; ELSE i := 4; END_IF;
    CASE i OF 1, 2: i := 3; 4..6, 8: i := 1; ELSE i := 0; END_CASE;
    CASE c OF Red: i := 1; Color#Blue: i := 2; END_CASE;
    FOR di := 10 TO 0 BY -2 DO IF di = 4 THEN EXIT; END_IF; CONTINUE; END_FOR;
    WHILE i < 3 DO i := i + 1; END_WHILE;
    REPEAT i := i - 1; UNTIL i < 0 END_REPEAT;
    ton1(IN := b, PT := T#1s, Q => b, ET => tm);
    ton1(b, T#2s);
    w.3 := TRUE;
    arr[1] := arr[2] + 1;
    p.x := 2.5;
    RETURN;
    """
    main, _ = checked(body)
    kinds = [type(s).__name__ for s in main.body]
    assert kinds == [
        "Assign",
        "If",
        "Case",
        "Case",
        "For",
        "While",
        "Repeat",
        "CallStmt",
        "CallStmt",
        "Assign",
        "Assign",
        "Assign",
        "Return",
    ]
    case = main.body[2]
    assert [[(lab.low.const, lab.high.const if lab.high else None) for lab in br.labels] for br in case.branches] == [
        [(1, None), (2, None)],
        [(4, 6), (8, None)],
    ]
    assert main.body[3].branches[1].labels[0].low.const == 6  # Color#Blue: Green := 5, then Blue is 6
    call = main.body[7].call
    assert call.fb.name == "TON" and call.target.name == "ton1"
    assert [(a.param.name, a.output) for a in call.args] == [("IN", False), ("PT", False), ("Q", True), ("ET", True)]
    assert [a.param.name for a in main.body[8].call.args] == ["IN", "PT"]  # informal: inputs in order
    loop = main.body[4]
    assert loop.step.const == -2 and isinstance(loop.body[1], t.Continue)


def test_enumeration_values_number_on_from_an_explicit_one():
    _, prog = checked("i := 0;")
    color = prog.types["COLOR"].type
    assert [(v.name, v.number) for v in color.values.values()] == [("Red", 0), ("Green", 5), ("Blue", 6)]
    assert prog.types["POINT"].type.members["TAG"].type.length == 8
    assert isinstance(prog.types["SMALL"].type, ty.SubrangeType) and prog.types["SMALL"].type.high == 100


def test_declarations_with_qualifiers_and_initial_values():
    text = """
    TYPE Vec : ARRAY[1..2, 1..3] OF INT := [1, 2, 4(0)]; END_TYPE
    VAR_GLOBAL CONSTANT LIMIT_HI : INT := 10; END_VAR
    VAR_GLOBAL RETAIN count : DINT := 5; END_VAR
    VAR_GLOBAL PERSISTENT total : LREAL; END_VAR
    FUNCTION_BLOCK Fb
    VAR_INPUT in1 : INT := 3; END_VAR
    VAR_OUTPUT out1 : INT; END_VAR
    VAR_IN_OUT io : INT; END_VAR
    VAR_TEMP scratch : INT; END_VAR
    VAR pts : ARRAY[0..LIMIT_HI - 1] OF REAL := [10(1.5)]; name : STRING[LIMIT_HI * 2] := 'x'; END_VAR
      out1 := in1 + io + LIMIT_HI;
      io := out1;
    END_FUNCTION_BLOCK
    PROGRAM Main
    VAR_EXTERNAL count : DINT; END_VAR
    VAR RETAIN f : Fb := (in1 := 4); x : INT; v : Vec; END_VAR
      f(in1 := 1, io := x, out1 => x);
      count := count + 1;
    END_PROGRAM
    """
    prog = compile_st({"main.st": text})
    fb = prog.pous["FB"]
    kinds = {v.name: v.kind for v in fb.vars}
    assert kinds == {
        "in1": "VAR_INPUT",
        "out1": "VAR_OUTPUT",
        "io": "VAR_IN_OUT",
        "scratch": "VAR_TEMP",
        "pts": "VAR",
        "name": "VAR",
    }
    pts = fb.locals["PTS"].type
    assert pts.dims == [(0, 9)] and str(pts.element) == "REAL"
    assert fb.locals["NAME"].type.length == 20
    assert prog.globals["COUNT"].retain and prog.globals["TOTAL"].persistent and prog.globals["LIMIT_HI"].constant
    main = prog.pous["MAIN"]
    assert main.locals["F"].retain and isinstance(main.locals["F"].type, ty.FbType)
    assert main.locals["COUNT"].kind == "VAR_EXTERNAL"


def test_configuration_resource_task_and_program_instances():
    text = """
    PROGRAM Main VAR x : INT; END_VAR x := x + 1; END_PROGRAM
    CONFIGURATION Cell
      VAR_GLOBAL mode : INT; END_VAR
      RESOURCE Cpu ON PLC
        TASK Fast (INTERVAL := T#2ms, PRIORITY := 1);
        TASK Slow (INTERVAL := T#100ms, PRIORITY := 5);
        PROGRAM Main1 WITH Fast : Main;
        PROGRAM Main2 WITH Slow : Main;
      END_RESOURCE
    END_CONFIGURATION
    """
    prog = compile_st({"main.st": text})
    (conf,) = prog.configurations
    (res,) = conf.resources
    assert [(tk.name, tk.params["INTERVAL"][1].const, tk.params["PRIORITY"][1].const) for tk in res.tasks] == [
        ("Fast", 2_000_000, 1),
        ("Slow", 100_000_000, 5),
    ]
    assert [(pc.name, pc.task, pc.pou.name) for pc in res.programs] == [
        ("Main1", "Fast", "Main"),
        ("Main2", "Slow", "Main"),
    ]
    assert "MODE" in prog.globals


def test_comments_of_every_form_and_pragmas():
    text = """
    (* a (* nested *) comment *) PROGRAM Main // a line comment
    VAR /* a C comment */ x : INT; { attribute 'hide' } END_VAR
      x := 1; (* 'a string in a comment' *)
      x := LEN('(* not a comment *)');
    END_PROGRAM
    """
    prog = compile_st({"main.st": text})
    main = prog.pous["MAIN"]
    assert main.body[1].value.args[0].value.value == "(* not a comment *)"
    assert main.body[1].place.line == 5 and main.body[1].place.col == 7


def test_every_node_has_its_place():
    main, _ = checked("i := arr[2] + 1;")
    assign = main.body[0]
    line = TYPES.count("\n") + DECLS.count("\n") + 5  # TYPES, PROGRAM, VAR, DECLS, END_VAR, then the body
    assert (assign.place.file, assign.place.line, assign.place.col) == ("main.st", line, 1)
    add = assign.value
    assert (add.place.line, add.place.col) == (line, 6)
    assert (add.left.place.line, add.left.place.col) == (line, 6)  # arr[2] starts where arr does
    assert (add.left.indices[0].place.line, add.left.indices[0].place.col) == (line, 10)


def test_function_result_and_informal_call():
    text = """
    FUNCTION Hyp : LREAL VAR_INPUT a : LREAL; b : LREAL; END_VAR Hyp := SQRT(a * a + b * b); END_FUNCTION
    PROGRAM Main VAR h : LREAL; END_VAR h := Hyp(3.0, 4.0); END_PROGRAM
    """
    prog = compile_st({"main.st": text})
    call = prog.pous["MAIN"].body[0].value
    assert call.target is prog.pous["HYP"] and str(call.type) == "LREAL"
    assert prog.pous["HYP"].body[0].target.decl is prog.pous["HYP"].result


def _expressions(node, seen=None):
    """Every Expr under node (dataclass fields, lists, tuples), each once."""
    seen = set() if seen is None else seen
    if id(node) in seen:
        return
    seen.add(id(node))
    if isinstance(node, t.Expr):
        yield node
    if isinstance(node, (list, tuple)):
        for item in node:
            yield from _expressions(item, seen)
    elif isinstance(node, t.Node):
        for name in node.__dataclass_fields__:
            if name not in (
                "type",
                "const",
                "decl",
                "target",
                "fb",
                "param",
                "owner",
                "glb",
                "enum",
                "result",
                "locals",
                "uses",
                "pou",
            ):
                yield from _expressions(getattr(node, name), seen)


def test_after_check_every_expression_has_its_type_and_every_name_its_declaration():
    seeds = Path(__file__).resolve().parents[2] / "fuzz" / "corpus" / "fuzz_st"
    prog = compile_st({p.name: p.read_text() for p in sorted(seeds.glob("[cl]*.st"))})
    exprs = list(_expressions(prog.units))
    assert len(exprs) > 250
    function_names = {id(e.callee) for e in exprs if isinstance(e, t.Call) and e.fb is None}
    for e in exprs:
        untyped = (isinstance(e, t.Call) and e.fb is not None) or id(e) in function_names  # FB calls, F in F(x)
        assert e.type is not None or untyped, f"{e.place}: {type(e).__name__} has no type"
        assert not isinstance(e.type, ty.LiteralType), f"{e.place}: {type(e).__name__} still untyped ({e.type})"
        if isinstance(e, (t.Name, t.Member)) and not isinstance(e.type, GlbPath):
            assert e.decl is not None, f"{e.place}: {e.name} has no declaration"
        if isinstance(e, t.Call):
            assert e.target is not None or e.fb is not None, f"{e.place}: a call without its target"


def test_a_call_as_a_statement_is_typed_with_its_arguments():
    """F(1, 2); and MUX(0, i, 1); drop their result, but are typed as any expression: the call has its
    type and every argument its own (the literals the call's type), as the code generator needs."""
    text = """
    FUNCTION Acc : INT
    VAR_INPUT add : INT; big : DINT; END_VAR
    VAR_IN_OUT total : INT; END_VAR
    VAR_OUTPUT twice : DINT; END_VAR
      total := total + add; twice := big * 2; Acc := total;
    END_FUNCTION
    FUNCTION Touch
    VAR_IN_OUT n : INT; END_VAR
      n := n + 1;
    END_FUNCTION
    PROGRAM Main
    VAR i : INT; si : SINT; d : DINT; r : REAL; END_VAR
      Acc(1, 2, i);
      Acc(add := si, big := 70000, total := i, twice => d);
      Touch(i);
      MUX(0, i, 1);
      MAX(1, 2);
      LIMIT(0.5, r, 2);
      SEL(TRUE, si, 1);
    END_PROGRAM
    """
    prog = compile_st({"main.st": text})
    calls = [s.call for s in prog.pous["MAIN"].body]
    assert [str(c.type) for c in calls] == ["INT", "INT", "None", "INT", "DINT", "REAL", "SINT"]
    assert [str(a.value.type) for a in calls[0].args] == ["INT", "DINT", "INT"]
    assert [str(a.value.type) for a in calls[3].args] == ["DINT", "INT", "INT"]  # MUX's K, then IN0, IN1
    assert [str(a.value.type) for a in calls[5].args] == ["REAL", "REAL", "REAL"]
    for e in _expressions(prog.pous["MAIN"].body):
        if e is not calls[2] and not any(e is c.callee for c in calls):  # Touch has no result
            assert e.type is not None and not isinstance(e.type, ty.LiteralType), f"{e.place}: {e.type}"


def _shape(e) -> str:
    if isinstance(e, t.Binary):
        return f"({_shape(e.left)} {e.op} {_shape(e.right)})"
    if isinstance(e, t.Unary):
        return f"({e.op} {_shape(e.operand)})"
    if isinstance(e, t.Literal):
        return e.text
    return e.name


def test_iec_precedence():
    main, _ = checked("b := b OR b XOR b AND r > -r ** 2.0 + r * 3.0 / r;", "b : BOOL; r : REAL;")
    assert _shape(main.body[0].value) == "(b OR (b XOR (b AND (r > ((- (r ** 2.0)) + ((r * 3.0) / r))))))"
    main, _ = checked("b := i = 1 & NOT b AND i MOD 2 <> 0;", "b : BOOL; i : INT;")
    assert _shape(main.body[0].value) == "(((i = 1) AND (NOT b)) AND ((i MOD 2) <> 0))"


def test_negated_output_argument():
    main, _ = checked("t1(IN := TRUE, PT := T#1s, NOT Q => idle);", "t1 : TON; idle : BOOL;")
    out = main.body[0].call.args[2]
    assert (out.param.name, out.output, out.negated) == ("Q", True, True)
