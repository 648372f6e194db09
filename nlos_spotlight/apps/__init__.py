"""User-facing tools on a trained run: ``nlos spotlight`` (where to aim the projector on a scanned
room) and ``nlos predict`` (position and posture from photographs or a video)."""
