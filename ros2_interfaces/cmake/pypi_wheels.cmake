# Included into every interface package's configuration by scripts/setup-ros2
# (-DCMAKE_PROJECT_INCLUDE=...) when it builds against the ROS 2 Jazzy wheels from PyPI.
#
# The wheels' exported CMake targets (<pkg>::<pkg>__rosidl_generator_py of action_msgs,
# builtin_interfaces, geometry_msgs, ...) name the include directories of the machine that
# built them (/opt/python/cp311-cp311/include/python3.11 and its numpy's), and CMake refuses
# to generate a build that uses an imported target with a directory that does not exist.
# The generated Python extensions get this Python's and numpy's include directories from
# rosidl_generator_py's own find_package(Python3 ... NumPy), so the missing ones are dropped,
# at the end of the package's configuration, from the targets that it imported. The
# packages' own files stay as they are; with a ROS 2 installation this file is not used.
cmake_minimum_required(VERSION 3.19)  # cmake_language(DEFER)

function(_rtcf_drop_missing_include_dirs)
  get_directory_property(targets DIRECTORY "${CMAKE_SOURCE_DIR}" IMPORTED_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(dirs "${target}" INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT dirs)
      continue()
    endif()
    set(kept "")
    set(dropped "")
    foreach(dir IN LISTS dirs)
      if(IS_ABSOLUTE "${dir}" AND NOT dir MATCHES "\\$<" AND NOT EXISTS "${dir}")
        list(APPEND dropped "${dir}")
      else()
        list(APPEND kept "${dir}")
      endif()
    endforeach()
    if(dropped)
      message(STATUS "rtcf: ${target}: dropped include directories of the wheels' build machine: ${dropped}")
      set_property(TARGET "${target}" PROPERTY INTERFACE_INCLUDE_DIRECTORIES "${kept}")
    endif()
  endforeach()
endfunction()

cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL _rtcf_drop_missing_include_dirs)
