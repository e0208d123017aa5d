"""Loosely coupled INS/GNSS (SPEC section 6).

Earth model, strapdown mechanisation, 21-state (27 with scale factors, one more after a
levelled standstill) error-state Kalman filter with GNSS position/velocity updates, and
the Rauch–Tung–Striebel smoother.

Frames: body X forward, Y right, Z down; navigation frame local NED; position as
geodetic latitude, longitude (rad inside the algorithms, deg at the file boundary) and
ellipsoidal height (WGS84).
"""
