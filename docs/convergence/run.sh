#!/usr/bin/env bash
# Regenerates the charts and tables of docs/convergence.md and the time-to-error table of
# docs/performance.md. Run from the repository root after `cargo build --release`; takes about
# 75 minutes on 2 cores. References go to target/converge-refs (not committed).
# ONLY="scene …" restricts it to some scenes; CHARTS=0 skips the comparison charts.
#
# Every bundled scene is scaled down to a quarter of its resolution, with a sixteenth of its
# photons per iteration (so the photon pass and the camera pass keep their balance); everything
# else is the scene's own settings.
set -euo pipefail
HAZE=${HAZE:-target/release/haze}
OUT=${OUT:-docs/convergence}
REFS=${REFS:-target/converge-refs}
REF_TIME=${REF_TIME:-150s}
RUN_TIME=${RUN_TIME:-30s}
CMP_TIME=${CMP_TIME:-20s}
mkdir -p "$OUT" "$REFS"

# scene, resolution, photons per iteration, integrator of the reference
scenes=(
  "cornell-box 96x96 12500 path"
  "glass-caustic 120x80 18750 photons"
  "cornell-fog 96x96 12500 path"
  "spotlight-fog 160x100 25000 path"
  "cornell-cloud 96x96 12500 path"
  "cornell-cloud-homogeneous 96x96 12500 path"
  "vdb-cloud 160x100 25000 path"
  "volumetric-caustic 250x141 12500 photons"
  "thin-fog 96x96 12500 path"
  "dense-fog 96x96 125 photons"
  "fog-forward 96x96 12500 path"
  "fog-backward 96x96 12500 path"
  "vdb-edges 96x96 12500 path"
)
ONLY=${ONLY:-}
CHARTS=${CHARTS:-1}
wanted() { [ -z "$ONLY" ] || [[ " $ONLY " == *" $1 "* ]]; }

for line in "${scenes[@]}"; do
  read -r name res photons ref <<<"$line"
  # The path tracer cannot see the caustics of a point light through glass (glass-caustic) and
  # barely finds the small light behind the sphere (volumetric-caustic): those references are long
  # photon-mapping runs with four times the photons.
  # dense-fog's path-traced reference is a scatter of single fireflies after 150 s (its light
  # reaches the camera along random walks of ~1000 steps from a lamp 0.8 m inside the fog):
  # photon mapping with 16x the light paths, split by importance, for 600 s instead (see
  # docs/performance.md, "Light paths split by importance", for its noise and kernel bias; the
  # earlier one, 64x the light paths unsplit, had 62 % relative noise of its own).
  # DENSE_REF_TIME overrides its 600 s; delete an older $REFS/dense-fog.exr by hand, since an
  # existing reference is reused.
  wanted "$name" || continue
  ref_photons=$((photons * 4)) ref_time=$REF_TIME ref_extra=()
  if [ "$name" = dense-fog ]; then
    ref_photons=$((photons * 16)) ref_time=${DENSE_REF_TIME:-600s}
    ref_extra=(--photon-splitting importance)
  fi
  if [ ! -f "$REFS/$name.exr" ]; then
    "$HAZE" render "scenes/$name.toml" --resolution "$res" -p "$ref_photons" \
      --integrator "$ref" --seed 1000 -t "$ref_time" --reference -q "${ref_extra[@]}" \
      -o "$REFS/$name.exr"
  fi
done

for line in "${scenes[@]}"; do
  read -r name res photons ref <<<"$line"
  wanted "$name" || continue
  common=(--reference "$REFS/$name.exr" --resolution "$res" -p "$photons" -q)
  if grep -q '^\[media' "scenes/$name.toml"; then
    series=(--series "hybrid beam:integrator=hybrid,volume_estimate=beam"
      --series "hybrid point:integrator=hybrid,volume_estimate=point"
      --series "photons beam:integrator=photons,volume_estimate=beam"
      --series "photons point:integrator=photons,volume_estimate=point")
  else
    series=(--series "hybrid:integrator=hybrid" --series "photons:integrator=photons")
  fi
  # The volumetric caustic's light covers a fraction of one pixel at 1000x the image mean, and the
  # glass sphere shows its image in a fraction of pixel (116, 44), which a sample hits about once
  # in 700 with a quarter of the light's radiance: either pixel alone would set the RMSE by
  # whether it was hit, so measure below both (rows 46-140).
  region=()
  if [ "$name" = volumetric-caustic ]; then region=(--region 0,46,250,141); fi
  # Light paths split by importance: the modes it was built for, where they are measured.
  if [ "$name" = dense-fog ]; then
    series+=(--series "photons beam split:integrator=photons,photon_splitting=importance"
      --series "combined split:integrator=combined,photon_splitting=importance")
  fi
  "$HAZE" converge "scenes/$name.toml" "${common[@]}" "${region[@]}" -t "$RUN_TIME" "${series[@]}" \
    --series "combined:integrator=combined" --series "path:integrator=path" \
    -o "$OUT/time-to-error-$name"
done

cmp() { # scene, output name, options...
  local name=$1 out=$2
  shift 2
  local line res photons
  for line in "${scenes[@]}"; do
    read -r n r p _ <<<"$line"
    if [ "$n" = "$name" ]; then res=$r; photons=$p; fi
  done
  # The charts were made with the hybrid, the default until 2026-12-07 (a comparison of
  # integrators sets each series' own).
  "$HAZE" converge "scenes/$name.toml" --reference "$REFS/$name.exr" --resolution "$res" \
    -p "$photons" -q --integrator hybrid "$@" -o "$OUT/$out"
}
[ "$CHARTS" = 1 ] || exit 0
cmp cornell-box alpha -t "$CMP_TIME" --compare alpha
cmp cornell-box progression -t "$CMP_TIME" --compare progression
cmp cornell-fog estimate -t "$CMP_TIME" --compare dimension --series "point:volume_estimate=point"
cmp cornell-fog volume-alpha -t "$CMP_TIME" --compare volume-alpha
cmp cornell-fog kernel -t "$CMP_TIME" --compare kernel
cmp cornell-fog photons -t "$CMP_TIME" --compare photons
cmp volumetric-caustic sds -t 60s --compare integrator --region 0,46,250,141
cmp spotlight-fog thinning -t 30s --series "no thinning:" --series "beam_cell_budget 16:beam_cell_budget=16"
