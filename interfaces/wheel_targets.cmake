# Included into each interface package's project() (CMAKE_PROJECT_INCLUDE) by
# tools/build_interfaces.py. The ROS 2 Jazzy wheels on PyPI export CMake targets
# (<pkg>::<pkg>__rosidl_generator_py) whose INTERFACE_INCLUDE_DIRECTORIES name the Python and
# numpy headers of the machine that built the wheels (/opt/python/cp311-cp311/...). CMake refuses
# a target with a missing include directory, so at the end of the configure step every imported
# target's missing Python or numpy header directory is pointed at this interpreter's. Nothing
# installed is edited; a missing directory of any other kind is left for CMake to report.
if(NOT DRS_PYTHON_INCLUDE_DIR OR NOT DRS_NUMPY_INCLUDE_DIR)
  message(FATAL_ERROR "wheel_targets.cmake needs -DDRS_PYTHON_INCLUDE_DIR and -DDRS_NUMPY_INCLUDE_DIR")
endif()

function(drs_point_wheel_targets_at_local_headers)
  get_property(targets DIRECTORY "${CMAKE_SOURCE_DIR}" PROPERTY IMPORTED_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT dirs)
      continue()
    endif()
    set(fixed "")
    set(changed FALSE)
    foreach(dir IN LISTS dirs)
      if(NOT EXISTS "${dir}" AND dir MATCHES "/include/python3\\.[0-9]+$")
        set(dir "${DRS_PYTHON_INCLUDE_DIR}")
        set(changed TRUE)
      elseif(NOT EXISTS "${dir}" AND dir MATCHES "/numpy/(_core|core)/include$")
        set(dir "${DRS_NUMPY_INCLUDE_DIR}")
        set(changed TRUE)
      endif()
      list(APPEND fixed "${dir}")
    endforeach()
    if(changed)
      list(REMOVE_DUPLICATES fixed)
      set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${fixed}")
    endif()
  endforeach()
endfunction()

cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL drs_point_wheel_targets_at_local_headers)
