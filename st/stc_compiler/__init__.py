# stc_compiler -- the IEC 61131-3 Structured Text compiler: st.lark -> tree.py -> check.py (-> emit_*.py).
