# Sourced by .ci/run: a throwaway PostgreSQL server for tests/test_postgres.py, on a Unix socket
# only (no TCP port), stopped when the run ends. Installs Debian's server where it is missing.
start_postgres() {
  if ! ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq postgresql >/dev/null
  fi
  local bin
  bin=$(ls -d /usr/lib/postgresql/*/bin | sort -V | tail -1)
  PG_DIR=$(mktemp -d /tmp/tdb-pg.XXXXXX)
  chown postgres "$PG_DIR"
  su postgres -s /bin/sh -c "$bin/initdb -D $PG_DIR/data -A trust -U postgres" >/dev/null
  su postgres -s /bin/sh -c "$bin/pg_ctl -D $PG_DIR/data -l $PG_DIR/log -w \
    -o \"-k $PG_DIR -p 54329 -c listen_addresses=''\" start" >/dev/null
  su postgres -s /bin/sh -c "$bin/createdb -h $PG_DIR -p 54329 tdbtest"
  PG_BIN=$bin
  export TDB_TEST_POSTGRES="postgresql+psycopg://postgres@/tdbtest?host=$PG_DIR&port=54329"
  echo "CI: PostgreSQL $("$bin/postgres" --version | awk '{print $3}') on $PG_DIR" >&2
}

stop_postgres() {
  if [ -n "${PG_DIR:-}" ]; then
    su postgres -s /bin/sh -c "$PG_BIN/pg_ctl -D $PG_DIR/data -m fast stop" >/dev/null 2>&1 || true
    rm -rf "$PG_DIR"
  fi
}
