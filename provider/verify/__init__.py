"""Verification tools: proof that the shipped shaders compute what the CPU computes.

* :mod:`.render`: a headless OpenGL context (moderngl + EGL), meshes, cameras;
* :mod:`.harness`: ``shlight validate-shaders`` (GLSL, and HLSL through SPIR-V);
* :mod:`.hlsl`: HLSL → SPIR-V → GLSL with glslang and spirv-cross;
* :mod:`.contract`: the contract vectors shared with the C# tests;
* :mod:`.pictures`: the comparison pictures against brute-force irradiance.
* :mod:`.lights`: the ambient + lights shader functions;
* :mod:`.ibl`, :mod:`.cubemap`, :mod:`.reflections`, :mod:`.ibl_pictures`: the image-based
  lighting (SH9 diffuse + the prefiltered cube's specular) against its CPU reference.

Built on :mod:`provider.core`.
"""
