# Debian packages (CPack's DEB generator; docs/PACKAGES.md), included last by the top
# CMakeLists.txt: mlprobe-host (the programs, the
# PCL reader plug-in, mlp-hostd's systemd unit and a configuration that starts) and mlprobe-fw
# (the probe's firmware and its unit; amd64 here, arm64 from the cross build). Maintainer
# scripts make the system user and folders and never touch the site's configuration, keys,
# calibrations or history. `cpack` in the build folder writes them; scripts/test-packages.sh
# installs, upgrades and removes them.

# The sample units name /usr/local/bin (installed by hand); the packages install to /usr/bin.
function(mlp_packaged_unit source out)
  file(READ ${source} text)
  string(REPLACE "/usr/local/bin/" "/usr/bin/" text "${text}")
  file(WRITE ${out} "${text}")
endfunction()

install(TARGETS mlp_fw_app RUNTIME DESTINATION bin COMPONENT fw)
mlp_packaged_unit(${CMAKE_SOURCE_DIR}/samples/probe_board/mlp-fw.service
                  ${CMAKE_BINARY_DIR}/packaging/mlp-fw.service)
install(FILES ${CMAKE_BINARY_DIR}/packaging/mlp-fw.service DESTINATION lib/systemd/system
        COMPONENT fw)
install(FILES ${CMAKE_SOURCE_DIR}/samples/probe_board/probe.env DESTINATION /etc/mlprobe
        COMPONENT fw)
set(packages fw)

if(NOT MLP_FIRMWARE_ONLY)
  install(TARGETS mlp mlp_hostd_app mlp_history_app mlp_calibrate_app mlp_tool_app
                  mlp_setter_app mlp_grind_app mlp_kinematics_app
          RUNTIME DESTINATION bin COMPONENT host)
  install(TARGETS mlp_pcl_reader LIBRARY DESTINATION lib COMPONENT host)  # dlopen: ../lib
  mlp_packaged_unit(${CMAKE_SOURCE_DIR}/samples/hostd/mlp-hostd.service
                    ${CMAKE_BINARY_DIR}/packaging/mlp-hostd.service)
  install(FILES ${CMAKE_BINARY_DIR}/packaging/mlp-hostd.service DESTINATION lib/systemd/system
          COMPONENT host)
  install(FILES ${CMAKE_SOURCE_DIR}/host/packaging/hostd.json DESTINATION /etc/mlprobe COMPONENT host)
  install(FILES ${CMAKE_SOURCE_DIR}/docs/HOSTD.md ${CMAKE_SOURCE_DIR}/docs/CLI.md
                ${CMAKE_SOURCE_DIR}/docs/PACKAGES.md
          DESTINATION share/doc/mlprobe-host COMPONENT host)
  list(APPEND packages host)
endif()

set(CPACK_GENERATOR DEB)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL ${packages})
set(CPACK_PACKAGE_NAME mlprobe)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_PACKAGE_CONTACT "mlprobe engineers <mlprobe@localhost>")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_HOST_PACKAGE_NAME mlprobe-host)
set(CPACK_DEBIAN_FW_PACKAGE_NAME mlprobe-fw)
set(CPACK_COMPONENT_HOST_DESCRIPTION
    "mlprobe host: the inspection service for a line-laser probe in a CNC machine\n mlp-hostd (probe link, jobs, offsets to the controller), mlp and its tools.")
set(CPACK_COMPONENT_FW_DESCRIPTION
    "mlprobe probe firmware: camera, MEMS mirror, laser; serves the host over the probe link")
# Dependencies from the programs' own shared libraries (dpkg-shlibdeps). The cross build has
# no arm64 libraries installed to ask: it names its few by hand (scripts/build-arm64.sh).
if(NOT CMAKE_CROSSCOMPILING)
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
elseif(CMAKE_SYSTEM_PROCESSOR STREQUAL "aarch64")
  set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE arm64)  # else dpkg's own: amd64
endif()
set(CPACK_DEBIAN_HOST_PACKAGE_CONTROL_EXTRA
    "${CMAKE_SOURCE_DIR}/host/packaging/postinst;${CMAKE_SOURCE_DIR}/host/packaging/prerm;${CMAKE_SOURCE_DIR}/host/packaging/postrm;${CMAKE_SOURCE_DIR}/host/packaging/conffiles")
set(CPACK_DEBIAN_FW_PACKAGE_CONTROL_EXTRA
    "${CMAKE_SOURCE_DIR}/probe_fw/packaging/postinst;${CMAKE_SOURCE_DIR}/probe_fw/packaging/prerm;${CMAKE_SOURCE_DIR}/probe_fw/packaging/conffiles")
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION TRUE)
include(CPack)
