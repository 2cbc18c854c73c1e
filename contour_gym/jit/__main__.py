"""``python -m contour_gym.jit``: what code each kernel slot runs, per built-in component."""

from contour_gym.jit.binding import slot_table

if __name__ == "__main__":
    import contour_gym  # noqa: F401  (registers the built-in components)

    for slot, family, component, where in slot_table():
        print(f"{slot:<13} {family:<22} {component:<22} {where}")
