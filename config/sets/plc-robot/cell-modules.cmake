# cell-modules.cmake -- plc_robot_cell_modules(<target> <out> <cell> <cell_out>): a cell whose PLC is
# compiled by stc (plc-robot-st, plc-robot-ld) gets the plc-robot set's other modules and files
# (Robot.so, the I/O dispatcher, the drive simulator, the URDF, ioconfig.xml, robot.json, dds.json)
# copied from <cell_out> (where plc-robot is built) into <out>, by the custom target <target>.
function(plc_robot_cell_modules target out cell cell_out)
  set(copied Robot.so libiodispat.so indurop-drivesim indurop6.urdf ioconfig.xml robot.json dds.json)
  list(TRANSFORM copied PREPEND ${out}/ OUTPUT_VARIABLE outputs)
  add_custom_command(
    OUTPUT ${outputs}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${out}
    COMMAND ${CMAKE_COMMAND} -E copy_if_different ${copied} ${out}
    WORKING_DIRECTORY ${cell_out}
    DEPENDS Robot plc_robot_io ${cell}/ioconfig.xml ${cell}/robot.json ${cell}/dds.json
    COMMENT "${target}: the plc-robot set's modules -> ${out}")
  add_custom_target(${target} ALL DEPENDS ${outputs})
endfunction()
