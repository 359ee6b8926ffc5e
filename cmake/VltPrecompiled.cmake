# Precompiled headers (CI's build time, docs/testing.md): the standard and Eigen headers that most
# of vlt's sources include are parsed once per target instead of once per source. Only headers
# from outside vlt, so a precompiled header never hides a missing include of vlt's own
# (the layering test reads the #include lines). -DCMAKE_DISABLE_PRECOMPILE_HEADERS=ON turns it off.
set(VLT_COMMON_HEADERS <algorithm> <cmath> <cstdint> <cstdio> <map> <memory> <set> <string>
                       <string_view> <vector> <Eigen/Core> <Eigen/Dense>)

function(vlt_precompile_common_headers target)
  target_precompile_headers(${target} PRIVATE ${VLT_COMMON_HEADERS})
endfunction()
