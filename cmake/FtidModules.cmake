# The module layers, declared once (docs/architecture.md, "Modules and the dependency rule").
# Each entry is one layer, lowest first; a module may link only modules of a LOWER layer
# (dependencies point down). src/CMakeLists.txt adds the modules in this order and then calls
# ftid_check_module_layers(), which fails the configure on an upward or same-layer link and on a
# module (ftid_add_library) that is not declared here. A new module: add it to its layer.
set(FTID_MODULE_LAYERS
  "fileio effects rt drivers_ur"                          # 0: leaves (plus common, header-only)
  "model logio trajectory params drivers_can config monitor" # 1: kinematics, file formats, parameter sets, CAN driver, payload monitor
  "samples sim motion transport simrobot"                 # 2: the one sample builder, simulator, robot motion, LCM
  "compensate identify simsensor daemon_client"           # 3: real-time compensation, offline identification, ftidd's command client (defined in src/daemon)
  "lab design daemon"                                     # 4: model laboratory, excitation design, ftidd
  "cell"                                                  # 5: `ftid --identify` and the demo cell
)

set(FTID_MODULES)
set(_ftid_level 0)
foreach(_layer IN LISTS FTID_MODULE_LAYERS)
  string(REPLACE " " ";" _layer_modules "${_layer}")
  foreach(_m IN LISTS _layer_modules)
    if(_m STREQUAL "")
      continue()
    endif()
    list(APPEND FTID_MODULES ${_m})
    set(FTID_MODULE_LEVEL_${_m} ${_ftid_level})
  endforeach()
  math(EXPR _ftid_level "${_ftid_level} + 1")
endforeach()

# The source directory of a module (drivers_ur -> drivers/ur).
function(ftid_module_dir module out)
  string(REGEX REPLACE "^drivers_" "drivers/" dir "${module}")
  set(${out} ${dir} PARENT_SCOPE)
endfunction()

# Fails the configure if a module links a module of its own or a higher layer, or if a module
# target is not declared in FTID_MODULE_LAYERS. Checks every entry of each module's
# LINK_LIBRARIES (PUBLIC and PRIVATE alike).
function(ftid_check_module_layers)
  get_property(targets GLOBAL PROPERTY FTID_MODULE_TARGETS)
  set(problems "")
  foreach(target IN LISTS targets)
    string(REGEX REPLACE "^ftid_" "" module "${target}")
    if(NOT DEFINED FTID_MODULE_LEVEL_${module})
      string(APPEND problems "\n  module '${module}' is not declared in FTID_MODULE_LAYERS (cmake/FtidModules.cmake)")
      continue()
    endif()
    set(level ${FTID_MODULE_LEVEL_${module}})
    get_target_property(deps ${target} LINK_LIBRARIES)
    if(NOT deps)
      continue()
    endif()
    foreach(dep IN LISTS deps)
      string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" dep "${dep}")
      if(NOT dep MATCHES "^ftid(_|::)")
        continue()
      endif()
      string(REGEX REPLACE "^ftid(_|::)" "" dep_module "${dep}")
      if(NOT DEFINED FTID_MODULE_LEVEL_${dep_module})
        continue()  # not a module (ftid::lcmtypes, ftid::kdl, ...)
      endif()
      set(dep_level ${FTID_MODULE_LEVEL_${dep_module}})
      if(NOT dep_level LESS level)
        string(APPEND problems "\n  ${module} (layer ${level}) links ${dep_module} (layer ${dep_level})")
      endif()
    endforeach()
  endforeach()
  if(problems)
    message(FATAL_ERROR "Module dependencies must point down (cmake/FtidModules.cmake, "
                        "docs/architecture.md):${problems}")
  endif()
endfunction()
