"""Snapshot of the public API: removing or renaming a public name must be a deliberate change here.

Also checks that every ``__all__`` is sorted and names something that exists.
"""

from __future__ import annotations

import importlib

import pytest

PUBLIC_API = {   'vergence': ['__version__'],
    'vergence.camera': ['Camera', 'MIN_FOCAL_PX', 'MIN_FOV_DEG', 'interpolate', 'look_at'],
    'vergence.depth': [   'MATCHERS', 'MAX_BLOCK_SIZE', 'MIN_INLIER_SHARE', 'MIN_TEXTURE', 'MIN_TEXTURED_PERCENT', 'PLANE_SCALES',
                          'PatchMatchParameters', 'PatchMatchResult', 'Rectification', 'RectifiedPair', 'RefinedDisparity',
                          'RegionScore', 'RowAlignment', 'SMOOTHING_METHODS', 'SegmentPlanes', 'compute_disparity',
                          'confidence_map', 'depth_from_disparity', 'disparity_from_depth', 'disparity_preview',
                          'evaluate_disparity', 'fill_from_planes', 'fill_occlusions', 'fit_segment_planes', 'left_right_check',
                          'mask_agreement', 'match_blocks', 'match_bm', 'match_patchmatch', 'match_sgbm', 'measure_row_alignment',
                          'middlebury_regions', 'nonoccluded_mask', 'patchmatch_stereo', 'read_middlebury_masks',
                          'rectify_cameras', 'rectify_pair', 'refine_disparity', 'remove_speckles', 'segment_image',
                          'sgbm_parameters', 'textured_pixels', 'unreliable_pixels', 'weighted_median_filter'],
    'vergence.display': [   'ANAGLYPH_METHODS', 'LAYOUTS', 'anaglyph', 'checkerboard', 'interleave', 'pack', 'side_by_side',
                            'tile_views', 'top_bottom'],
    'vergence.io': [   'CAMERA_FORMATS', 'CameraFormat', 'CameraSet', 'DEPTH_KINDS', 'HEADER_FORMATS', 'ImageHeader', 'MAX_JSON_BYTES', 'MAX_JSON_DEPTH', 'atomic_folder', 'atomic_write', 'cameras_for_images',
                       'read_bundler', 'read_cameras', 'read_cameras_json', 'read_colmap', 'read_depth',
                       'read_disparity', 'read_header', 'read_image', 'read_json', 'read_middlebury_par', 'read_pfm', 'stores_integers',
                       'write_bundler', 'write_cameras', 'write_cameras_json', 'write_colmap', 'write_disparity',
                       'write_image', 'write_json', 'write_middlebury_par', 'write_pfm'],
    'vergence.metrics': ['MAX_REGISTRATION_RADIUS', 'MIN_CONTRAST', 'REGISTRATION_PATCH', 'RegistrationError', 'SSIM_WINDOW',
                         'dssim', 'patch_contrast', 'psnr', 'registration_error', 'ssim'],
    'vergence.render': ['AO_PATTERNS', 'BUILTIN_SCENES', 'Checker', 'Diffuse', 'Environment', 'FisheyeCamera', 'Glass', 'Hits', 'IOR_RANGE', 'Intersector', 'MAX_DEPTH', 'MAX_RADIANCE', 'MAX_RENDER_BYTES', 'MAX_RENDER_RAYS', 'MAX_RENDER_SIDE', 'MAX_SCENE_EXTENT', 'MIN_FOV_DEG', 'Mesh', 'Mirror', 'RAY_GENERATORS', 'RayBatch', 'RayTree', 'Rectangle', 'RenderCost', 'RenderResult', 'RenderSettings', 'SUBPIXEL_OFFSET_RANGE', 'Scene', 'SceneCamera', 'Sphere', 'Stereo', 'StereoPreview', 'Texture', 'Tracer', 'WhittedShader', 'auto_exposure', 'builtin_scene', 'camera_rays', 'layer_names', 'load_scene', 'open_scene', 'render', 'render_cost', 'render_curved', 'render_stereo', 'scene_from_dict', 'schlick', 'screen_disparity', 'select_variant', 'stereo_preview', 'subpixel_rays', 'tonemap', 'trace_curved'],
    'vergence.report.html': ['Figure', 'Grid', 'Section', 'render_report', 'write_report'],
    'vergence.report.preview': ['contact_sheet', 'depth_preview', 'save_render'],
    'vergence.report.specular_outputs': ['SPECULAR_METHODS', 'SPECULAR_OUTPUT_FILES', 'write_specular_outputs'],
    'vergence.report.video_analysis': ['ANALYSIS_REPORT_FILES', 'plot_disparity_over_time', 'write_analysis_report'],
    'vergence.report.rig_plot': ['FIGURE_FORMATS', 'FIGURE_SIZE', 'ROLE_COLORS', 'frustum_wedge', 'plot_rig', 'top_view_basis'],
    'vergence.report.stereospace_map': ['MAP_FIGURE_SIZE', 'QUALITY_SCALE', 'navigation_map', 'region_triangles'],
    'vergence.rigs': ['ELEMENT_NAME_PATTERN', 'EXAMPLE_SHOTS', 'QuadriRig', 'RIG_EYES', 'RigCamera', 'SHOT_RIGS', 'Shot', 'ShotCamera', 'TRI_REFERENCES', 'TriRig',
                      'WorldDistortion', 'load_shot', 'plan_document', 'plan_quadri_rig', 'plan_tri_rig', 'shot_from_dict', 'stereo_pair'],
    'vergence.specular': ['ABSOLUTE_VARIANTS', 'COMFORT_MARGIN_ARCMIN', 'CONTRAST_SATURATION_JND', 'CONTRAST_WINDOW', 'COST_TERMS', 'COST_WEIGHTS', 'CostTerms', 'DEFAULT_VARIANT', 'DESCENT_STEPS', 'DISPLAY_FITS', 'DISTINCTIVENESS_SCALE', 'EPSILON_FRACTION', 'FILL_WEIGHT', 'FIRST_STEP', 'IMPORTANCE_FLOOR', 'Importance', 'LAYER_MATCH_METHODS', 'LayerDisparity', 'LayerState', 'MATCH_WINDOW', 'MAX_OFFSET_STEPS', 'MAX_TABLE_BYTES', 'MOSTLY_OUTSIDE', 'NEAR_SURFACE_ARCMIN', 'OffsetAnalysis', 'OffsetPlan', 'OffsetPlanner', 'OffsetSolution', 'OffsetTable', 'PLAN_FACTOR', 'PLAN_SIGMA_RANGE', 'PerceivedLightness', 'RELATIVE_LAMBDA_ARCMIN', 'REPAIR_STEPS', 'RESTARTS', 'RIVALRY_TOLERANCE', 'RIVALRY_WINDOW', 'RenderCheck', 'RepairedRender', 'Rivalry', 'SAME_SURFACE_FRACTION', 'SEPARATION_ARCMIN', 'SSD_WINDOW', 'SpecularResult', 'SpecularTable', 'TABLE_FILE', 'TABLE_FORMAT', 'VERTICAL_TOLERANCE_ARCMIN', 'ZoneCount', 'analyse_table', 'arcmin_per_pixel', 'check_render', 'comfort_share', 'contrast_q', 'csf_lowpass', 'csf_mannos_sakrison', 'disparity_arcmin', 'disparity_cost', 'disparity_cost_gradient', 'display_block', 'distinctiveness', 'fill_matches', 'fit_display', 'importance', 'joint_bilateral_upsample', 'layer_disparity', 'layer_labels', 'layer_lightness', 'lightness_from_srgb', 'near_surface', 'object_shares', 'offset_camera', 'offset_rays', 'offset_table_bytes', 'on_surface', 'optimise_offsets', 'peli_contrast', 'perceived_lightness', 'pixels_per_degree', 'push_pull_fill', 'read_specular_table', 'render_offsets', 'repair_render', 'rivalry', 'scene_diameter', 'specular_from_table', 'specular_objects', 'specular_stereo', 'tabulate_offsets', 'weighted_block_mean', 'write_specular_table', 'zone_count', 'zone_warnings'],
    'vergence.stereospace': ['BuiltSpace', 'CAMERA_STATUSES', 'COLLECTION_ARC_DEG', 'COLLECTION_VIEWS', 'CONSISTENCY_TOLERANCE', 'CONSISTENCY_VIEWS', 'CONSISTENCY_VOTES', 'CONSISTENCY_WINDOW', 'CameraGraph', 'Collection', 'ConvergenceShift', 'DEFAULT_DISPLAY', 'DISPARITY_MARGIN_PX', 'DISPARITY_TRIM', 'DISTORTION_LIMIT', 'FRAMINGS', 'JUMP_CONE_DEG', 'JUMP_SAMPLES', 'MATCH_NEIGHBOURS', 'MAX_AXIS_ANGLE_DEG', 'MAX_COLLECTION_VIEWS', 'MAX_PAN_JUMPS', 'MAX_REPROJECTION_ERROR_PX', 'MAX_VIEW_SIDE', 'MIN_SHARED_POINTS', 'MLS_MIN_HANDLES', 'MOVE_EVENTS', 'Move', 'NEAR_FACTOR', 'NOVEL_VIEW_METHODS', 'NovelView', 'PAIR_METHODS', 'PARALLEL_SINE', 'PSNR_CEIL_DB', 'PSNR_FLOOR_DB', 'PreparedCollection', 'RATIO_TEST', 'RELATIVE_TOLERANCE', 'RING_CLOSURE', 'RankedState', 'S2View', 'S2_HANDLE_CELL_PX', 'S2_MAX_SOURCES', 'S2_PENALTY_FLOOR', 'S2_THRESHOLD_SCALE', 'SPACE_FILE', 'SPACE_FORMAT_VERSION', 'StereoPairResult', 'StereoSpace', 'StereoState', 'TEXTURE_MIN_STD', 'TEXTURE_WINDOW', 'UP_AGREEMENT', 'UP_DISTINCT', 'UP_MIN_COSINE', 'VertexQuality', 'best_states', 'build_space', 'camera_graph', 'camera_roster', 'capture_paths', 'check_depth', 'collection_up', 'convergence_shift', 'eye_order', 'frame_cameras', 'leave_one_out', 'load_collection', 'load_space', 'map_frame', 'mls_similarity', 'mls_warp', 'neighbours', 'novel_view', 'pair_cameras', 'pair_quality', 'pan', 'pan_sign', 'plane_view', 'project_distorted', 'render_collection', 's2_view', 'save_space', 'source_depth', 'source_depths', 'space_from_graph', 'start_state', 'state_at_camera', 'state_near', 'stereo_pair', 'stereo_point', 'tangent', 'triangulate_points', 'vertex_pairs', 'vertex_quality', 'vertex_state', 'write_space', 'zoom'],
    'vergence.synthesis': [   'BAYES_DEFORMATION_CAP', 'BAYES_DEPTH_CONTINUITY', 'BAYES_GEOMETRIC_CAP', 'BAYES_GRADIENT_THRESHOLD',
                              'BAYES_MIN_DEFORMATION', 'BAYES_SIGMA_DEPTH', 'BAYES_SIGMA_SENSOR', 'DEPTH_KINDS', 'FILL_METHODS', 'IBRResult', 'IBRSource', 'IBR_INTERPOLATIONS', 'IBR_LINK_LIMIT_PX', 'IBR_WEIGHTS', 'INVERSE_DEPTH_RANGE', 'MAX_FILTER_RADIUS', 'MAX_PARALLAX_WIDTHS',
                              'MAX_SMOOTH_SIGMA', 'MAX_SYNTHESIS_BYTES', 'MAX_VIEWS', 'MIN_METRIC_DEPTH', 'MIN_PARALLAX_PX', 'MOSTLY_HOLES_FRACTION', 'NEARNESS_UNITS', 'ParallaxPlan', 'StereoResult',
                              'ViewQuality', 'WARP_ORDERS', 'WarpedView', 'assess_view', 'backward_warp',
                              'baseline_weights', 'bayesian_weights', 'blend_views', 'contour_mask', 'dilate_foreground', 'epipole', 'error_image',
                              'fill_disparity', 'fill_holes', 'forward_warp', 'holes_warnings', 'interpolate_view',
                              'median_refine', 'nearness_from_depth', 'plan_comfort', 'plan_parallax', 'refine_camera_warp', 'render_ibr', 'smooth_depth',
                              'stereo_warnings', 'synthesize_stereo', 'synthesize_view', 'synthesize_views', 'views_offsets',
                              'warp_to_camera'],
    'vergence.video': ['CLIP_SHOTS', 'CONVERT_ORIGINS', 'CUT_BINS', 'CUT_SAMPLE_SIDE', 'CUT_THRESHOLD', 'ClipAnalysis', 'ClipShot', 'Conversion', 'DEFAULT_CRF', 'DEFAULT_FOLDER_FPS', 'DEFAULT_PIXEL_FORMAT', 'DEFAULT_PRESET', 'DepthClip', 'FRAME_SUFFIXES', 'Flicker', 'FlickerMeter', 'FrameReader', 'FrameStats', 'HISTOGRAM_STEP_PX', 'LAYOUT_TAGS', 'MIN_SHOT_FRAMES', 'PERCENTILES', 'PIXEL_FORMATS', 'RetargetedViews', 'SPLIT_FRAMES', 'STABILIZE_ALPHA', 'STATIC_THRESHOLD', 'STEREO_LAYOUTS', 'ShotConversion', 'ShotCuts', 'ShotStats', 'StereoClip', 'TestClips', 'VERTICAL_MAX_WIDTH', 'VIDEO_LAYOUTS', 'VIDEO_SUFFIXES', 'VISIBLE_RTOL', 'VideoInfo', 'VideoWriter', 'WINDOW_BAND', 'WINDOW_MIN_PX', 'WINDOW_SHARE', 'X264_PRESETS', 'analyze_clip', 'check_new_output', 'convert_clip', 'converted_path', 'detect_cuts', 'disparity_flicker', 'guess_layout', 'histogram_change', 'layout_video_name', 'make_test_clips', 'open_depth_clip', 'open_frames', 'open_stereo', 'render_retargeted', 'retargeted_rig', 'split_frame', 'stabilize_disparity'],
    'vergence.viewing': [   'BlendedMapping', 'CARDBOARD_ROUNDNESS', 'CONTROL_EFFECTS', 'ComfortReport',
                            'ComfortZone', 'ConstrainedMapping', 'DISPLAY_PRESETS', 'DepthBudget',
                            'DepthSample', 'DirectorConstraint', 'DisparityMapping', 'Display',
                            'LENGTH_RANGE', 'LinearMapping', 'LogMapping', 'MAX_ABS_DISPARITY', 'MAX_SCENE_DEPTH',
                            'MAX_VERGENCE_ARCMIN', 'PiecewiseMapping', 'ROUNDNESS_RANGE', 'RationalHermiteMapping',
                            'SaliencyMapping', 'Shooting', 'arcmin_from_pixels', 'check_disparity_range', 'check_display',
                            'default_depths', 'depth_budget', 'disparity', 'divergence_baseline',
                            'divergence_depth', 'focal_ratio', 'gradient_domain_mapping',
                            'mapped_perceived_depth', 'mapped_roundness', 'perceived_depth',
                            'perceived_depth_from_depth', 'pixels_from_arcmin', 'psi_from_constraints',
                            'roundness', 'roundness_baseline', 'scene_depth_from_disparity',
                            'shift_sensor_parallax', 'shift_sensor_positions', 'temporal_mapping'],
    'vergence.warm': ['WARM_GROUPS', 'WarmGroup', 'kernel_signatures', 'warm'],
    'vergence.web': ['JobCancelled', 'MAX_JSON_BODY', 'MAX_UPLOAD_BYTES', 'MAX_UPLOAD_PIXELS', 'create_app']}


@pytest.mark.parametrize("module", sorted(PUBLIC_API))
def test_public_names_are_stable_sorted_and_exist(module):
    if module == "vergence.web":
        pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
    mod = importlib.import_module(module)
    assert list(mod.__all__) == sorted(mod.__all__), f"{module}.__all__ is not sorted"
    assert sorted(mod.__all__) == PUBLIC_API[module]
    missing = [name for name in mod.__all__ if not hasattr(mod, name)]
    assert not missing


def test_importing_vergence_does_not_import_heavy_engines():
    import subprocess
    import sys

    code = "import sys, vergence, vergence.viewing, vergence.camera; print(' '.join(m for m in ('mitsuba', 'numba', 'matplotlib') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""
